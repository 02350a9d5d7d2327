//! Each test as a statistic of the point results it reads (`resolve` builds it): which results ("cells") it draws,
//! and the function of their values whose interval decides the claim. The same function gives
//! the value at the means and every bootstrap draw, so the value and its interval agree.

use super::data::SceneConstants;
use super::fit_value::{fit_parameter, group_value, GroupValue};
use super::spec::{Bound, Direction, FitModel};
use crate::observe::fits::linear_fit;

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
    Outside(f64, f64),
}

impl Side {
    pub fn of(b: &Bound) -> Option<Side> {
        match (b.below, b.above, b.within, b.outside) {
            (Some(t), None, None, None) => Some(Side::Below(t)),
            (None, Some(t), None, None) => Some(Side::Above(t)),
            (None, None, Some([lo, hi]), None) => Some(Side::Within(lo, hi)),
            (None, None, None, Some([lo, hi])) => Some(Side::Outside(lo, hi)),
            _ => None,
        }
    }

    /// As the claims table writes it.
    pub fn text(&self) -> String {
        match self {
            Side::Below(t) => format!("< {}", short(*t)),
            Side::Above(t) => format!("> {}", short(*t)),
            Side::Within(a, b) => format!("in [{}, {}]", short(*a), short(*b)),
            Side::Outside(a, b) => format!("outside [{}, {}]", short(*a), short(*b)),
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
    pub(super) kind: Kind,
}

/// How a statistic's cells make its value.
pub(super) enum Kind {
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

/// A fit's x: a parameter's value, or a cell's (a result).
#[derive(Clone, Copy)]
pub(super) enum XOf {
    Fixed(f64),
    Cell(usize),
}

/// What a series of groups along a parameter is tested for.
pub(super) enum SeriesShape {
    Trend(Direction),
    /// Interior group indices considered (the ends are the first and last group).
    MinimumInside(Vec<usize>),
}

impl Statistic {
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
