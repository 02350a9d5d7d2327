//! A claim as a campaign file writes it: the paper's words and one test from a closed
//! vocabulary (`compare`, `trend`, `minimum_inside`, `fit`), each naming the results and the
//! points it reads. Parsed here; checked against a campaign's points in `campaign::claims`.

use std::collections::BTreeMap;

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

/// A paper's statement, and the one test that decides it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Claim {
    /// Short name, unique in the file (letters, digits, '_', '-', '.').
    pub id: String,
    /// The paper's words.
    pub statement: String,
    /// Where the paper says it ("PRE 102, 042902, Fig. 4").
    #[serde(default, skip_serializing_if = "String::is_empty")]
    pub paper: String,
    /// The paper's own number, as text ("about 5 % below Q(0)"), shown beside sweep's.
    #[serde(default, skip_serializing_if = "String::is_empty")]
    pub paper_value: String,
    /// A result at one point against another point or a value.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub compare: Option<Compare>,
    /// A monotonic rise or fall of a result along one swept parameter.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub trend: Option<Trend>,
    /// A result's minimum along a swept parameter lies strictly inside its range.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub minimum_inside: Option<MinimumInside>,
    /// A fitted parameter or goodness of fit against a value or range.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fit: Option<Fit>,
}

/// Which of the four tests a claim carries.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TestKind {
    Compare,
    Trend,
    MinimumInside,
    Fit,
}

impl TestKind {
    pub fn name(self) -> &'static str {
        match self {
            TestKind::Compare => "compare",
            TestKind::Trend => "trend",
            TestKind::MinimumInside => "minimum_inside",
            TestKind::Fit => "fit",
        }
    }
}

impl Claim {
    /// The tests given (a valid claim has exactly one).
    pub fn tests(&self) -> Vec<TestKind> {
        let mut out = Vec::new();
        if self.compare.is_some() {
            out.push(TestKind::Compare);
        }
        if self.trend.is_some() {
            out.push(TestKind::Trend);
        }
        if self.minimum_inside.is_some() {
            out.push(TestKind::MinimumInside);
        }
        if self.fit.is_some() {
            out.push(TestKind::Fit);
        }
        out
    }
}

/// Parameter values that pick points: every point whose parameters equal these.
pub type At = BTreeMap<String, f64>;

/// What a value is held against: exactly one of `below`, `above`, `within`, `outside` (the
/// fields of `compare` and `fit`).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Bound {
    pub below: Option<f64>,
    pub above: Option<f64>,
    pub within: Option<[f64; 2]>,
    pub outside: Option<[f64; 2]>,
}

/// How two values are compared.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum CompareAs {
    /// value / other.
    #[default]
    Ratio,
    /// value − other.
    Difference,
}

/// `compare`: Q(D = 5.5 d, f = 0.3 Hz) / Q(D = 5.5 d, f = 0) below 1.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Compare {
    /// The result compared (silo: "q"; chute: "D", "shear_rate", "D_over_shear_rate", "V_x",
    /// "phi").
    pub result: String,
    /// Chute: the block (height k L to (k+1) L); absent: the central bed (0.3 H < z < 0.7 H).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub block: Option<i64>,
    /// The point.
    pub at: At,
    /// The other point (the same result there); or give `value`, `against_block` or
    /// `against_result`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub against: Option<At>,
    /// Chute: the same result of the same point in block k (the base against the centre).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub against_block: Option<i64>,
    /// Another result of the same point, in the same block (the gap at the base against the
    /// gap in the centre).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub against_result: Option<String>,
    /// A fixed value in the result's unit; or give `against`, `against_block` or `against_result`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub value: Option<f64>,
    /// "ratio" (default) or "difference".
    #[serde(default, rename = "as")]
    pub compare_as: CompareAs,
    /// The claim holds when the value is below this (or give `above`, `within` or `outside`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub below: Option<f64>,
    /// The claim holds when the value is above this.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub above: Option<f64>,
    /// The claim holds when the value is inside [lo, hi].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub within: Option<[f64; 2]>,
    /// The claim holds when the value is outside [lo, hi] (a skewness "far from zero").
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub outside: Option<[f64; 2]>,
}

/// Rising or falling.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum Direction {
    Rising,
    Falling,
}

/// `trend`: Q rises with f at D = 2.6 d. Decided by the least-squares slope of the result
/// against the parameter (its sign) and by every step between neighbouring points (none may go
/// significantly the other way). Chute: `along: "block"` runs up the blocks of the one point
/// `at` picks, over the blocks `range` names (the correlation length grows towards the surface).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Trend {
    /// The result (as in `compare`), or a fit's parameter "janda.d_min_m", "janda.c",
    /// "beverloo.k", … fitted over D at each value of `along`.
    pub result: String,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub block: Option<i64>,
    /// The swept parameter the trend runs along, or "block" (chute heights, one point).
    pub along: String,
    /// The other parameters, fixed.
    #[serde(default)]
    pub at: At,
    pub direction: Direction,
    /// Only the points with `along` in [lo, hi]; absent: all. Along "block": the first and last
    /// block, required.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub range: Option<[f64; 2]>,
}

/// `minimum_inside`: some point strictly inside the range of `along` is significantly below
/// both ends (the smallest and largest `along` of the points).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct MinimumInside {
    pub result: String,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub block: Option<i64>,
    pub along: String,
    #[serde(default)]
    pub at: At,
    /// The interior points considered, by `along` in [lo, hi] (the paper's "near 0.3 Hz");
    /// absent: every interior point.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub inside: Option<[f64; 2]>,
}

/// The laws a `fit` can fit.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum FitModel {
    /// Silo, Eq. (1): Q = C (1 − α1 e^{−D/α2}) D^{5/2} over the orifice diameter. Parameters
    /// "c", "alpha1", "alpha2_m", "d_min_m", "d_min_over_d" (D_min / particle diameter).
    Janda,
    /// Silo: Q = C ρ_b √g (D − k d)^{5/2}. Parameters "c", "k".
    Beverloo,
    /// A straight line y = a x + b through the points (x, y: results or swept parameters).
    /// Parameters "slope", "intercept", "r".
    Line,
    /// A line through the origin y = a x. Parameters "slope", "r" (the correlation of y
    /// with x).
    Proportional,
}

impl FitModel {
    pub fn name(self) -> &'static str {
        match self {
            FitModel::Janda => "janda",
            FitModel::Beverloo => "beverloo",
            FitModel::Line => "line",
            FitModel::Proportional => "proportional",
        }
    }

    /// The parameters the model gives.
    pub fn parameters(self) -> &'static [&'static str] {
        match self {
            FitModel::Janda => &["c", "alpha1", "alpha2_m", "d_min_m", "d_min_over_d"],
            FitModel::Beverloo => &["c", "k"],
            FitModel::Line => &["slope", "intercept", "r"],
            FitModel::Proportional => &["slope", "r"],
        }
    }

    /// The model of a trend's result "janda.d_min_m" and its parameter.
    pub fn of_result(result: &str) -> Option<(FitModel, &str)> {
        let (m, p) = result.split_once('.')?;
        let model = match m {
            "janda" => FitModel::Janda,
            "beverloo" => FitModel::Beverloo,
            _ => return None,
        };
        Some((model, p))
    }
}

/// `fit`: Janda's D_min at f = 0 within [3, 5] d; the slope of D against γ̇ d⊥² above 0.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Fit {
    pub model: FitModel,
    /// The parameter tested (see `model`).
    pub parameter: String,
    /// The points fitted: every point with these parameters.
    #[serde(default)]
    pub at: At,
    /// Line fits: x, a result or a swept parameter ("shear_rate_d_perp2", "aspect_ratio").
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub x: Option<String>,
    /// Line fits: y, a result ("D").
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub y: Option<String>,
    /// Chute: the block the results are read in; absent: the bulk.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub block: Option<i64>,
    /// The claim holds when the value is below this (or give `above`, `within` or `outside`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub below: Option<f64>,
    /// The claim holds when the value is above this.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub above: Option<f64>,
    /// The claim holds when the value is inside [lo, hi].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub within: Option<[f64; 2]>,
    /// The claim holds when the value is outside [lo, hi] (a skewness "far from zero").
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub outside: Option<[f64; 2]>,
}

impl Compare {
    pub fn bound(&self) -> Bound {
        Bound {
            below: self.below,
            above: self.above,
            within: self.within,
            outside: self.outside,
        }
    }
}

impl Fit {
    pub fn bound(&self) -> Bound {
        Bound {
            below: self.below,
            above: self.above,
            within: self.within,
            outside: self.outside,
        }
    }
}
