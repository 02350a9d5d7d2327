//! Each test as a statistic of the point results it reads: which results ("cells") it draws,
//! and the function of their values whose interval decides the claim. The same function gives
//! the value at the means and every bootstrap draw, so the value and its interval agree.

use super::data::{result_key, select, PointData, SceneConstants};
use super::spec::{Bound, Claim, Direction, FitModel};
use crate::observe::fits::{beverloo_fit, janda_fit, linear_fit};

/// One result at one point: what a draw redraws.
#[derive(Clone, Debug, PartialEq)]
pub struct Cell {
    pub point: usize,
    pub key: String,
}

/// What the statistic holds its value against.
#[derive(Clone, Debug, PartialEq)]
pub enum Side {
    Below(f64),
    Above(f64),
    Within(f64, f64),
}

impl Side {
    pub fn of(b: &Bound) -> Option<Side> {
        match (b.below, b.above, b.within) {
            (Some(t), None, None) => Some(Side::Below(t)),
            (None, Some(t), None) => Some(Side::Above(t)),
            (None, None, Some([lo, hi])) => Some(Side::Within(lo, hi)),
            _ => None,
        }
    }

    /// As the claims table writes it.
    pub fn text(&self) -> String {
        match self {
            Side::Below(t) => format!("< {}", short(*t)),
            Side::Above(t) => format!("> {}", short(*t)),
            Side::Within(a, b) => format!("in [{}, {}]", short(*a), short(*b)),
        }
    }
}

/// A number as the tables write it: 4 significant digits.
pub fn short(v: f64) -> String {
    if v == 0.0 || (1e-3..1e4).contains(&v.abs()) {
        let s = format!("{v:.4}");
        let s = s.trim_end_matches('0').trim_end_matches('.');
        s.to_string()
    } else {
        format!("{v:.3e}")
    }
}

/// What a statistic gives for one set of values: its value and, for a trend, the steps
/// between neighbouring points (positive: in the claimed direction).
#[derive(Clone, Debug, PartialEq)]
pub struct Sample {
    pub value: f64,
    pub steps: Vec<f64>,
}

/// A claim's test, resolved against the points: the cells it reads, how they make its value,
/// and the side that supports the claim.
pub struct Statistic {
    pub cells: Vec<Cell>,
    pub side: Side,
    /// What the value is, in words ("Q ratio", "relative slope per Hz").
    pub what: String,
    kind: Kind,
}

enum Kind {
    Compare {
        ratio: bool,
        fixed: Option<f64>,
    },
    /// Cells grouped by the `along` value (`xs`), each group one series value.
    Series {
        xs: Vec<f64>,
        groups: Vec<Vec<usize>>,
        per_group: GroupValue,
        shape: SeriesShape,
    },
    Fit {
        model: FitModel,
        parameter: String,
        /// x of each y cell (a parameter), or the index of its x cell.
        x: Vec<XOf>,
        ys: Vec<usize>,
        scene: Option<SceneConstants>,
    },
}

#[derive(Clone, Copy)]
enum XOf {
    Fixed(f64),
    Cell(usize),
}

enum GroupValue {
    /// The group's one cell.
    One,
    /// A fit over the group's cells (x: their orifice diameters).
    Fit {
        model: FitModel,
        parameter: String,
        d_m: Vec<Vec<f64>>,
        scene: Option<SceneConstants>,
    },
}

enum SeriesShape {
    Trend(Direction),
    /// Interior group indices considered (the ends are the first and last group).
    MinimumInside(Vec<usize>),
}

/// Why a claim cannot be resolved against the points (a validation problem: the field and
/// what was expected).
#[derive(Clone, Debug, PartialEq)]
pub struct Unresolved {
    pub field: String,
    pub message: String,
}

fn unresolved(field: &str, message: String) -> Unresolved {
    Unresolved {
        field: field.into(),
        message,
    }
}

/// The single point matching `at`, or why not.
fn one_point(points: &[PointData], at: &super::spec::At, field: &str) -> Result<usize, Unresolved> {
    let found = select(points, at);
    match found.as_slice() {
        [i] => Ok(*i),
        [] => Err(unresolved(
            field,
            format!(
                "no point of the campaign has {}; expected values the campaign sweeps",
                at_text(at)
            ),
        )),
        many => Err(unresolved(
            field,
            format!(
                "{} points have {} ({} …); expected the parameters that pick one point",
                many.len(),
                at_text(at),
                points[many[0]].label
            ),
        )),
    }
}

pub fn at_text(at: &super::spec::At) -> String {
    if at.is_empty() {
        return "(any)".into();
    }
    at.iter()
        .map(|(k, v)| format!("{k}={}", short(*v)))
        .collect::<Vec<_>>()
        .join(", ")
}

/// The points matching `at`, grouped by their value of `along` (sorted), each group's points.
fn along_groups(
    points: &[PointData],
    at: &super::spec::At,
    along: &str,
    range: Option<[f64; 2]>,
    field: &str,
) -> Result<(Vec<f64>, Vec<Vec<usize>>), Unresolved> {
    let mut chosen: Vec<(f64, usize)> = Vec::new();
    for i in select(points, at) {
        let Some(&x) = points[i].params.get(along) else {
            return Err(unresolved(
                &format!("{field}.along"),
                format!("'{along}' is not a numeric parameter of the campaign's points"),
            ));
        };
        if range.is_none_or(|[lo, hi]| x >= lo - 1e-12 && x <= hi + 1e-12) {
            chosen.push((x, i));
        }
    }
    chosen.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
    let mut xs: Vec<f64> = Vec::new();
    let mut groups: Vec<Vec<usize>> = Vec::new();
    for (x, i) in chosen {
        match xs.last() {
            Some(&last) if super::data::same_value(last, x) => groups.last_mut().unwrap().push(i),
            _ => {
                xs.push(x);
                groups.push(vec![i]);
            }
        }
    }
    Ok((xs, groups))
}

fn check_result(result: &str, known: &[&str], field: &str) -> Result<(), Unresolved> {
    if known.contains(&result) {
        Ok(())
    } else {
        Err(unresolved(
            field,
            format!(
                "'{result}' is not a result of this scene; expected one of {}",
                known.join(", ")
            ),
        ))
    }
}

fn check_param(model: FitModel, parameter: &str, field: &str) -> Result<(), Unresolved> {
    if model.parameters().contains(&parameter) {
        Ok(())
    } else {
        Err(unresolved(
            field,
            format!(
                "'{parameter}' is not a parameter of the {} fit; expected one of {}",
                model.name(),
                model.parameters().join(", ")
            ),
        ))
    }
}

impl Statistic {
    /// Resolves claim `c` (at `path`, e.g. "claims[1]") against `points` of a scene giving
    /// `results`; `scene` is needed by the silo fits.
    ///
    /// # Errors
    /// The claim names a point the campaign lacks, a result the scene does not compute, a fit
    /// parameter the model lacks, or has not exactly one test or one bound.
    pub fn resolve(
        c: &Claim,
        path: &str,
        points: &[PointData],
        results: &[&str],
        scene: Option<SceneConstants>,
    ) -> Result<Statistic, Unresolved> {
        let tests = c.tests();
        if tests.len() != 1 {
            return Err(unresolved(
                path,
                format!(
                    "expected exactly one test (compare, trend, minimum_inside or fit), got {}",
                    if tests.is_empty() {
                        "none".to_string()
                    } else {
                        tests
                            .iter()
                            .map(|t| t.name())
                            .collect::<Vec<_>>()
                            .join(", ")
                    }
                ),
            ));
        }
        let silo = results.contains(&"q");
        if let Some(t) = &c.compare {
            let f = format!("{path}.compare");
            check_result(&t.result, results, &format!("{f}.result"))?;
            if t.block.is_some() && silo {
                return Err(unresolved(
                    &format!("{f}.block"),
                    "blocks are chute heights; a silo result has none".into(),
                ));
            }
            let side = Side::of(&t.bound()).ok_or_else(|| {
                unresolved(&f, "expected exactly one of below, above, within".into())
            })?;
            let key = result_key(&t.result, t.block);
            let a = one_point(points, &t.at, &format!("{f}.at"))?;
            let mut cells = vec![Cell {
                point: a,
                key: key.clone(),
            }];
            match (&t.against, t.value) {
                (Some(other), None) => {
                    let b = one_point(points, other, &format!("{f}.against"))?;
                    if b == a {
                        return Err(unresolved(
                            &format!("{f}.against"),
                            "is the same point as 'at'; expected another point".into(),
                        ));
                    }
                    cells.push(Cell { point: b, key });
                }
                (None, Some(_)) => {}
                _ => {
                    return Err(unresolved(
                        &f,
                        "expected exactly one of 'against' (another point) and 'value'".into(),
                    ))
                }
            }
            let ratio = t.compare_as == super::spec::CompareAs::Ratio;
            return Ok(Statistic {
                cells,
                side,
                what: format!(
                    "{} {}",
                    t.result,
                    if ratio { "ratio" } else { "difference" }
                ),
                kind: Kind::Compare {
                    ratio,
                    fixed: t.value,
                },
            });
        }
        if let Some(t) = &c.trend {
            let f = format!("{path}.trend");
            let per_fit = FitModel::of_result(&t.result);
            match per_fit {
                Some((model, p)) => {
                    if !silo || !matches!(model, FitModel::Janda | FitModel::Beverloo) {
                        return Err(unresolved(
                            &format!("{f}.result"),
                            format!(
                                "'{}' is a silo fit's parameter; this scene gives {}",
                                t.result,
                                results.join(", ")
                            ),
                        ));
                    }
                    check_param(model, p, &format!("{f}.result"))?;
                }
                None => check_result(&t.result, results, &format!("{f}.result"))?,
            }
            let (xs, groups) = along_groups(points, &t.at, &t.along, t.range, &f)?;
            if xs.len() < 2 {
                return Err(unresolved(
                    &f,
                    format!(
                        "{} value(s) of '{}' among the points with {}; expected at least 2",
                        xs.len(),
                        t.along,
                        at_text(&t.at)
                    ),
                ));
            }
            let (cells, groups, per_group) =
                series_cells(points, &xs, &groups, &t.result, t.block, per_fit, scene, &f)?;
            let unit = match t.direction {
                Direction::Rising => Side::Above(0.0),
                Direction::Falling => Side::Below(0.0),
            };
            return Ok(Statistic {
                cells,
                side: unit,
                what: format!("slope of {} along {} / mean", t.result, t.along),
                kind: Kind::Series {
                    xs,
                    groups,
                    per_group,
                    shape: SeriesShape::Trend(t.direction),
                },
            });
        }
        if let Some(t) = &c.minimum_inside {
            let f = format!("{path}.minimum_inside");
            check_result(&t.result, results, &format!("{f}.result"))?;
            let (xs, groups) = along_groups(points, &t.at, &t.along, None, &f)?;
            let interior: Vec<usize> = (1..xs.len().saturating_sub(1))
                .filter(|&k| {
                    t.inside
                        .is_none_or(|[lo, hi]| xs[k] >= lo - 1e-12 && xs[k] <= hi + 1e-12)
                })
                .collect();
            if xs.len() < 3 || interior.is_empty() {
                return Err(unresolved(&f, format!("expected two ends and at least one point inside{} along '{}' among the points with {}; found {} value(s)", t.inside.map_or(String::new(), |[a, b]| format!(" [{}, {}]", short(a), short(b))), t.along, at_text(&t.at), xs.len())));
            }
            let (cells, groups, per_group) =
                series_cells(points, &xs, &groups, &t.result, t.block, None, scene, &f)?;
            return Ok(Statistic {
                cells,
                side: Side::Below(0.0),
                what: format!("lowest inside point / higher end − 1 of {}", t.result),
                kind: Kind::Series {
                    xs,
                    groups,
                    per_group,
                    shape: SeriesShape::MinimumInside(interior),
                },
            });
        }
        let t = c.fit.as_ref().expect("one test");
        let f = format!("{path}.fit");
        check_param(t.model, &t.parameter, &format!("{f}.parameter"))?;
        let side = Side::of(&t.bound())
            .ok_or_else(|| unresolved(&f, "expected exactly one of below, above, within".into()))?;
        let chosen = select(points, &t.at);
        let mut cells = Vec::new();
        let mut x = Vec::new();
        let mut ys = Vec::new();
        match t.model {
            FitModel::Janda | FitModel::Beverloo => {
                if !silo {
                    return Err(unresolved(
                        &format!("{f}.model"),
                        format!(
                            "the {} law is the silo's; expected line or proportional",
                            t.model.name()
                        ),
                    ));
                }
                if t.x.is_some() || t.y.is_some() {
                    return Err(unresolved(
                        &f,
                        format!(
                            "the {} law fits Q against the orifice diameter; expected no x or y",
                            t.model.name()
                        ),
                    ));
                }
                for &i in &chosen {
                    let Some(&d) = points[i].params.get("orifice_diameter_m") else {
                        continue;
                    };
                    x.push(XOf::Fixed(d));
                    ys.push(cells.len());
                    cells.push(Cell {
                        point: i,
                        key: "q".into(),
                    });
                }
                if t.model == FitModel::Beverloo && scene.is_none() {
                    return Err(unresolved(
                        &f,
                        "the Beverloo law needs the particle diameter, bulk density and gravity"
                            .into(),
                    ));
                }
            }
            FitModel::Line | FitModel::Proportional => {
                let (Some(xn), Some(yn)) = (&t.x, &t.y) else {
                    return Err(unresolved(
                        &f,
                        format!(
                            "a {} fit needs x and y (results or swept parameters)",
                            t.model.name()
                        ),
                    ));
                };
                check_result(yn, results, &format!("{f}.y"))?;
                let x_is_result = results.contains(&xn.as_str());
                for &i in &chosen {
                    if x_is_result {
                        x.push(XOf::Cell(cells.len()));
                        cells.push(Cell {
                            point: i,
                            key: result_key(xn, t.block),
                        });
                    } else {
                        let Some(&v) = points[i].params.get(xn.as_str()) else {
                            return Err(unresolved(
                                &format!("{f}.x"),
                                format!(
                                    "'{xn}' is neither a result ({}) nor a numeric parameter",
                                    results.join(", ")
                                ),
                            ));
                        };
                        x.push(XOf::Fixed(v));
                    }
                    ys.push(cells.len());
                    cells.push(Cell {
                        point: i,
                        key: result_key(yn, t.block),
                    });
                }
            }
        }
        let needed = match t.model {
            FitModel::Janda => 4,
            FitModel::Beverloo | FitModel::Line => 3,
            FitModel::Proportional => 2,
        };
        if ys.len() < needed {
            return Err(unresolved(
                &format!("{f}.at"),
                format!(
                    "{} point(s) have {}; a {} fit needs at least {needed}",
                    ys.len(),
                    at_text(&t.at),
                    t.model.name()
                ),
            ));
        }
        Ok(Statistic {
            cells,
            side,
            what: format!("{} {}", t.model.name(), t.parameter),
            kind: Kind::Fit {
                model: t.model,
                parameter: t.parameter.clone(),
                x,
                ys,
                scene,
            },
        })
    }

    /// The statistic of one set of cell values (NaN where it cannot be computed: a fit that
    /// fails, a ratio over zero).
    pub fn sample(&self, v: &[f64]) -> Sample {
        match &self.kind {
            Kind::Compare { ratio, fixed } => {
                let other = fixed.unwrap_or_else(|| v[1]);
                let value = if *ratio { v[0] / other } else { v[0] - other };
                Sample {
                    value,
                    steps: Vec::new(),
                }
            }
            Kind::Series {
                xs,
                groups,
                per_group,
                shape,
            } => {
                let ys: Vec<f64> = groups
                    .iter()
                    .enumerate()
                    .map(|(g, cells)| group_value(per_group, g, cells, v))
                    .collect();
                match shape {
                    SeriesShape::Trend(dir) => {
                        let sign = if *dir == Direction::Rising { 1.0 } else { -1.0 };
                        let mean = ys.iter().sum::<f64>() / ys.len() as f64;
                        let slope = linear_fit(xs, &ys).map_or(f64::NAN, |l| l.slope);
                        let scale = if mean != 0.0 { mean.abs() } else { 1.0 };
                        let steps = ys
                            .windows(2)
                            .map(|w| sign * (w[1] - w[0]) / scale)
                            .collect();
                        Sample {
                            value: slope / scale,
                            steps,
                        }
                    }
                    SeriesShape::MinimumInside(interior) => {
                        let (l, r) = (ys[0], ys[ys.len() - 1]);
                        let depth = interior
                            .iter()
                            .map(|&k| (ys[k] / l).max(ys[k] / r))
                            .fold(f64::INFINITY, f64::min);
                        Sample {
                            value: depth - 1.0,
                            steps: Vec::new(),
                        }
                    }
                }
            }
            Kind::Fit {
                model,
                parameter,
                x,
                ys,
                scene,
            } => {
                let xv: Vec<f64> = x
                    .iter()
                    .map(|x| match x {
                        XOf::Fixed(v) => *v,
                        XOf::Cell(c) => v[*c],
                    })
                    .collect();
                let yv: Vec<f64> = ys.iter().map(|&c| v[c]).collect();
                Sample {
                    value: fit_parameter(*model, parameter, &xv, &yv, *scene),
                    steps: Vec::new(),
                }
            }
        }
    }
}

/// The cells of a series: one per point (the result), grouped by `along`, or every point of a
/// group for a fit per group.
#[allow(clippy::too_many_arguments)]
fn series_cells(
    points: &[PointData],
    xs: &[f64],
    groups: &[Vec<usize>],
    result: &str,
    block: Option<i64>,
    per_fit: Option<(FitModel, &str)>,
    scene: Option<SceneConstants>,
    field: &str,
) -> Result<(Vec<Cell>, Vec<Vec<usize>>, GroupValue), Unresolved> {
    let mut cells = Vec::new();
    let mut out = Vec::new();
    match per_fit {
        None => {
            for (g, members) in groups.iter().enumerate() {
                if members.len() > 1 {
                    return Err(unresolved(field, format!("{} points at {} ({} and {}); expected 'at' to fix every other swept parameter", members.len(), short(xs[g]), points[members[0]].label, points[members[1]].label)));
                }
                out.push(vec![cells.len()]);
                cells.push(Cell {
                    point: members[0],
                    key: result_key(result, block),
                });
            }
            Ok((cells, out, GroupValue::One))
        }
        Some((model, parameter)) => {
            let mut d_m = Vec::new();
            for members in groups {
                let mut ids = Vec::new();
                let mut ds = Vec::new();
                for &i in members {
                    if let Some(&d) = points[i].params.get("orifice_diameter_m") {
                        ids.push(cells.len());
                        ds.push(d);
                        cells.push(Cell {
                            point: i,
                            key: "q".into(),
                        });
                    }
                }
                if ds.len() < 4 {
                    return Err(unresolved(
                        field,
                        format!(
                            "a {} fit at each value needs at least 4 orifices; found {}",
                            model.name(),
                            ds.len()
                        ),
                    ));
                }
                out.push(ids);
                d_m.push(ds);
            }
            if model == FitModel::Beverloo && scene.is_none() {
                return Err(unresolved(
                    field,
                    "the Beverloo law needs the scene's constants".into(),
                ));
            }
            Ok((
                cells,
                out,
                GroupValue::Fit {
                    model,
                    parameter: parameter.to_string(),
                    d_m,
                    scene,
                },
            ))
        }
    }
}

fn group_value(per_group: &GroupValue, g: usize, cells: &[usize], v: &[f64]) -> f64 {
    match per_group {
        GroupValue::One => v[cells[0]],
        GroupValue::Fit {
            model,
            parameter,
            d_m,
            scene,
        } => {
            let q: Vec<f64> = cells.iter().map(|&c| v[c]).collect();
            fit_parameter(*model, parameter, &d_m[g], &q, *scene)
        }
    }
}

/// A model's parameter fitted through (x, y); NaN when the fit fails.
fn fit_parameter(
    model: FitModel,
    parameter: &str,
    x: &[f64],
    y: &[f64],
    scene: Option<SceneConstants>,
) -> f64 {
    match model {
        FitModel::Janda => {
            let Some(f) = janda_fit(x, y, None) else {
                return f64::NAN;
            };
            match parameter {
                "c" => f.c,
                "alpha1" => f.alpha1,
                "alpha2_m" => f.alpha2_m,
                "d_min_m" => f.d_min_m.unwrap_or(f64::NAN),
                "d_min_over_d" => match (f.d_min_m, scene) {
                    (Some(d), Some(s)) => d / s.particle_diameter_m,
                    _ => f64::NAN,
                },
                _ => f64::NAN,
            }
        }
        FitModel::Beverloo => {
            let Some(s) = scene else { return f64::NAN };
            let Some(f) = beverloo_fit(
                x,
                y,
                s.particle_diameter_m,
                s.bulk_density_kg_per_m3,
                s.gravity_m_per_s2,
            ) else {
                return f64::NAN;
            };
            match parameter {
                "c" => f.c,
                "k" => f.k,
                _ => f64::NAN,
            }
        }
        FitModel::Line => {
            let Some(l) = linear_fit(x, y) else {
                return f64::NAN;
            };
            match parameter {
                "slope" => l.slope,
                "intercept" => l.intercept,
                "r" => l.r,
                _ => f64::NAN,
            }
        }
        FitModel::Proportional => {
            let sxx: f64 = x.iter().map(|a| a * a).sum();
            let sxy: f64 = x.iter().zip(y).map(|(a, b)| a * b).sum();
            match parameter {
                "slope" if sxx > 0.0 => sxy / sxx,
                "r" => linear_fit(x, y).map_or(f64::NAN, |l| l.r),
                _ => f64::NAN,
            }
        }
    }
}
