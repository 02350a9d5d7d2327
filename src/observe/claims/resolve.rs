//! Resolving a claim against a campaign's points: which points and results its test reads,
//! checked by field (a point the campaign lacks, a result the scene does not compute, a fit
//! parameter the model lacks), and the statistic that reads them.

use super::data::{result_key, select, PointData, SceneConstants};
use super::fit_value::GroupValue;
use super::scope::{
    at_text, check_block, check_param, check_result, one_point, unresolved, Scope, Unresolved,
};
use super::spec::{At, Claim, Compare, CompareAs, Direction, FitModel, MinimumInside, Trend};
use super::statistic::{short, Cell, Kind, SeriesShape, Side, Statistic};

/// The points matching `at`, grouped by their value of `along` (sorted), each group's points.
fn along_groups(
    points: &[PointData],
    at: &At,
    along: &str,
    range: Option<[f64; 2]>,
    field: &str,
) -> Result<(Vec<f64>, Vec<Vec<usize>>), Unresolved> {
    let mut chosen: Vec<(f64, usize)> = Vec::new();
    for i in select(points, at)
        .into_iter()
        .filter(|&i| !points[i].clogged)
    {
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
        let cx = Scope {
            path,
            points,
            results,
            scene,
            silo,
        };
        if let Some(t) = &c.compare {
            return compare(t, &cx);
        }
        if let Some(t) = &c.trend {
            return trend(t, &cx);
        }
        if let Some(t) = &c.minimum_inside {
            return minimum_inside(t, &cx);
        }
        super::fit_resolve::fit(c.fit.as_ref().expect("one test"), &cx)
    }
}

fn compare(t: &Compare, cx: &Scope) -> Result<Statistic, Unresolved> {
    let Scope {
        path,
        points,
        results,
        silo,
        ..
    } = *cx;
    let f = format!("{path}.compare");
    check_result(&t.result, results, &format!("{f}.result"))?;
    if t.block.is_some() && silo {
        return Err(unresolved(
            &format!("{f}.block"),
            "blocks are chute heights; a silo result has none".into(),
        ));
    }
    let side = Side::of(&t.bound()).ok_or_else(|| {
        unresolved(
            &f,
            "expected exactly one of below, above, within, outside".into(),
        )
    })?;
    check_block(&t.result, t.block, &f)?;
    let key = result_key(&t.result, t.block);
    let a = one_point(points, &t.at, &format!("{f}.at"))?;
    let mut cells = vec![Cell {
        point: a,
        key: key.clone(),
    }];
    match (&t.against, t.value, t.against_block, &t.against_result) {
        (Some(other), None, None, None) => {
            let b = one_point(points, other, &format!("{f}.against"))?;
            if b == a {
                return Err(unresolved(
                    &format!("{f}.against"),
                    "is the same point as 'at'; expected another point".into(),
                ));
            }
            cells.push(Cell { point: b, key });
        }
        (None, Some(_), None, None) => {}
        (None, None, Some(k), None) => {
            let field = format!("{f}.against_block");
            if silo {
                return Err(unresolved(
                    &field,
                    "blocks are chute heights; a silo result has none".into(),
                ));
            }
            check_block(&t.result, Some(k), &f)?;
            if t.block == Some(k) {
                return Err(unresolved(
                    &field,
                    format!("is block {k}, the block compared; expected another block"),
                ));
            }
            cells.push(Cell {
                point: a,
                key: result_key(&t.result, Some(k)),
            });
        }
        (None, None, None, Some(other)) => {
            let field = format!("{f}.against_result");
            check_result(other, results, &field)?;
            check_block(other, t.block, &f)?;
            if *other == t.result {
                return Err(unresolved(
                    &field,
                    format!("is '{other}', the result compared; expected another result"),
                ));
            }
            cells.push(Cell {
                point: a,
                key: result_key(other, t.block),
            });
        }
        _ => {
            return Err(unresolved(
                &f,
                "expected exactly one of 'against' (another point), 'against_block', \
                 'against_result' and 'value'"
                    .into(),
            ))
        }
    }
    let ratio = t.compare_as == CompareAs::Ratio;
    Ok(Statistic {
        cells,
        side,
        what: match &t.against_result {
            Some(other) => format!("{} {} {}", t.result, if ratio { "/" } else { "−" }, other),
            None => format!(
                "{} {}",
                t.result,
                if ratio { "ratio" } else { "difference" }
            ),
        },
        kind: Kind::Compare {
            ratio,
            fixed: t.value,
        },
    })
}

fn trend(t: &Trend, cx: &Scope) -> Result<Statistic, Unresolved> {
    let Scope {
        path,
        points,
        results,
        scene,
        silo,
    } = *cx;
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
    check_block(&t.result, t.block, &f)?;
    if t.along == ALONG_BLOCKS {
        return trend_up_blocks(t, cx, &f);
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
    Ok(Statistic {
        cells,
        side: unit,
        what: format!("slope of {} along {} / mean", t.result, t.along),
        kind: Kind::Series {
            xs,
            groups,
            per_group,
            shape: SeriesShape::Trend(t.direction),
        },
    })
}

/// A trend's `along` that runs up the heights of one chute point instead of across points.
pub const ALONG_BLOCKS: &str = "block";

/// `trend` along "block": the result in blocks range[0]..=range[1] of the one point `at` picks,
/// as a series over the block index (z / L).
fn trend_up_blocks(t: &Trend, cx: &Scope, f: &str) -> Result<Statistic, Unresolved> {
    if cx.silo {
        return Err(unresolved(
            &format!("{f}.along"),
            "blocks are chute heights; a silo point has none".into(),
        ));
    }
    if t.block.is_some() {
        return Err(unresolved(
            &format!("{f}.block"),
            "a trend along the blocks reads every block of 'range'; expected no 'block'".into(),
        ));
    }
    // Read in every block of the range: a bed-part result has none.
    check_block(&t.result, Some(0), f)?;
    let Some([lo, hi]) = t.range else {
        return Err(unresolved(
            &format!("{f}.range"),
            "a trend along the blocks needs the first and last block, e.g. [3, 12]".into(),
        ));
    };
    let whole = |v: f64| v.fract() == 0.0 && v >= 0.0;
    if !whole(lo) || !whole(hi) || hi < lo + 1.0 {
        return Err(unresolved(
            &format!("{f}.range"),
            format!(
                "expected two block indices, first < last, got [{}, {}]",
                short(lo),
                short(hi)
            ),
        ));
    }
    let point = one_point(cx.points, &t.at, &format!("{f}.at"))?;
    let (lo, hi) = (lo as i64, hi as i64);
    let xs: Vec<f64> = (lo..=hi).map(|k| k as f64).collect();
    let cells: Vec<Cell> = (lo..=hi)
        .map(|k| Cell {
            point,
            key: result_key(&t.result, Some(k)),
        })
        .collect();
    let groups = (0..cells.len()).map(|g| vec![g]).collect();
    let side = match t.direction {
        Direction::Rising => Side::Above(0.0),
        Direction::Falling => Side::Below(0.0),
    };
    Ok(Statistic {
        cells,
        side,
        what: format!("slope of {} along the blocks / mean", t.result),
        kind: Kind::Series {
            xs,
            groups,
            per_group: GroupValue::One,
            shape: SeriesShape::Trend(t.direction),
        },
    })
}

fn minimum_inside(t: &MinimumInside, cx: &Scope) -> Result<Statistic, Unresolved> {
    let Scope {
        path,
        points,
        results,
        scene,
        ..
    } = *cx;
    let f = format!("{path}.minimum_inside");
    check_result(&t.result, results, &format!("{f}.result"))?;
    check_block(&t.result, t.block, &f)?;
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
    Ok(Statistic {
        cells,
        side: Side::Below(0.0),
        what: format!("lowest inside point / higher end − 1 of {}", t.result),
        kind: Kind::Series {
            xs,
            groups,
            per_group,
            shape: SeriesShape::MinimumInside(interior),
        },
    })
}

/// A series' cells, their indices per group, and how a group gives its value.
type SeriesCells = (Vec<Cell>, Vec<Vec<usize>>, GroupValue);

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
) -> Result<SeriesCells, Unresolved> {
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
