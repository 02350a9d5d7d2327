//! A claim decided on the points' pooled results: each result is redrawn from its own sampling
//! distribution (Student t with its degrees of freedom around its mean), the statistic is
//! computed for every draw, and the interval between its percentiles at the look's level is
//! held against the claim's side. Seeded, so the same results give the same verdict.

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal, StudentT};
use sha2::{Digest, Sha256};

use super::data::{Estimate, PointData};
use super::statistic::{Side, Statistic};

/// The error rate a campaign's verdicts keep over all its rounds together.
pub const ALPHA: f64 = 0.05;

/// Draws per verdict: the tails at α / (2 looks) still hold tens of draws for ≤ 9 looks.
pub const DRAWS: usize = 8000;

/// The two-sided confidence of each look when a campaign looks at its claims at most `looks`
/// times: α split evenly over the looks (Bonferroni), so the chance that any look gives a false
/// verdict is at most α, however the rounds in between were chosen.
pub fn look_level(looks: u32) -> f64 {
    1.0 - ALPHA / f64::from(looks.max(1))
}

/// The two-sided confidence of look `look` (0-based) of at most `looks`, when earlier versions
/// of the campaign spent `carried` of α and its own looks before this one were at the levels
/// `before`: the α still left, split evenly over the looks still to come (this one included).
/// Looks that kept to the even split give exactly its level, so a campaign whose number of looks
/// never changed looks as it always did; one whose `max_rounds` was raised, or that continues an
/// earlier version, never spends more than α in all. None when no α is left.
pub fn spending_level(looks: u32, look: u32, carried: f64, before: &[f64]) -> Option<f64> {
    let even = look_level(looks);
    if carried == 0.0 && before.iter().all(|&l| l == even) {
        return Some(even);
    }
    let spent = carried + before.iter().map(|l| 1.0 - l).sum::<f64>();
    let left = ALPHA - spent;
    let looks_left = looks.saturating_sub(look).max(1);
    (left > 1e-9).then(|| 1.0 - left / f64::from(looks_left))
}

/// A claim's standing.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Decision {
    Supported,
    Contradicted,
    /// The interval straddles the bound, or a result is missing.
    Undecided,
}

impl Decision {
    pub fn name(self) -> &'static str {
        match self {
            Decision::Supported => "supported",
            Decision::Contradicted => "contradicted",
            Decision::Undecided => "undecided",
        }
    }

    pub fn parse(s: &str) -> Option<Decision> {
        match s {
            "supported" => Some(Decision::Supported),
            "contradicted" => Some(Decision::Contradicted),
            "undecided" => Some(Decision::Undecided),
            _ => None,
        }
    }
}

/// A claim's verdict at one look.
#[derive(Clone, Debug, PartialEq)]
pub struct Verdict {
    pub decision: Decision,
    /// The statistic at the pooled means (NaN when it cannot be computed).
    pub value: f64,
    /// Its interval at `level` (NaN when unknown).
    pub lo: f64,
    pub hi: f64,
    /// Two-sided confidence of [lo, hi] at this look.
    pub level: f64,
    pub side: Side,
    /// What the value is.
    pub what: String,
    /// The points read, by index.
    pub points: Vec<usize>,
    /// Why undecided without an interval, or a trend's step that went the other way.
    pub note: String,
    /// Per point read: its share of the value's variance (value units²), the measure of how
    /// much its uncertainty keeps the claim undecided.
    pub variance_by_point: Vec<(usize, f64)>,
}

impl Verdict {
    /// Undecided without an interval (a claim that cannot be computed, or a look without α).
    pub fn undecided(level: f64, what: &str) -> Verdict {
        Verdict {
            decision: Decision::Undecided,
            value: f64::NAN,
            lo: f64::NAN,
            hi: f64::NAN,
            level,
            side: Side::Below(f64::NAN),
            what: what.into(),
            points: Vec::new(),
            note: String::new(),
            variance_by_point: Vec::new(),
        }
    }

    /// How far the value lies from the bound it must clear to be decided (value units):
    /// the half-width the interval must shrink to. 0 on the bound; NaN without a value.
    pub fn gap(&self) -> f64 {
        let v = self.value;
        match self.side {
            Side::Below(t) | Side::Above(t) => (v - t).abs(),
            Side::Within(a, b) | Side::Outside(a, b) => (v - a).abs().min((v - b).abs()),
        }
    }

    /// The interval's half-width now.
    pub fn half_width(&self) -> f64 {
        0.5 * (self.hi - self.lo)
    }
}

/// A verdict's seed: from the campaign, the claim and the look, so that re-evaluating the same
/// results gives the same bits.
pub fn seed_of(campaign: &str, claim: &str, look: u32) -> u64 {
    let h = Sha256::digest(format!("{campaign}\u{0}{claim}\u{0}{look}").as_bytes());
    u64::from_le_bytes(h[..8].try_into().expect("8 bytes"))
}

fn draw_t(e: &Estimate, rng: &mut ChaCha8Rng) -> f64 {
    let z: f64 = if e.dof.is_finite() && e.dof >= 1.0 && e.dof < 1e6 {
        match StudentT::new(e.dof) {
            Ok(t) => t.sample(rng),
            Err(_) => StandardNormal.sample(rng),
        }
    } else {
        StandardNormal.sample(rng)
    };
    e.mean + e.se * z
}

/// The `q`-quantile of sorted `v` (linear between order statistics).
fn quantile(v: &[f64], q: f64) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    let x = q * (v.len() - 1) as f64;
    let (i, f) = (x.floor() as usize, x - x.floor());
    if i + 1 >= v.len() {
        v[v.len() - 1]
    } else {
        v[i] * (1.0 - f) + v[i + 1] * f
    }
}

fn undecided(
    stat: &Statistic,
    points: Vec<usize>,
    level: f64,
    value: f64,
    note: String,
) -> Verdict {
    Verdict {
        decision: Decision::Undecided,
        value,
        lo: f64::NAN,
        hi: f64::NAN,
        level,
        side: stat.side.clone(),
        what: stat.what.clone(),
        points,
        note,
        variance_by_point: Vec::new(),
    }
}

/// Decides `stat` on `points` at two-sided confidence `level`, with draws seeded by `seed`.
pub fn decide(stat: &Statistic, points: &[PointData], level: f64, seed: u64) -> Verdict {
    let mut used: Vec<usize> = stat.cells.iter().map(|c| c.point).collect();
    used.sort_unstable();
    used.dedup();
    let mut est = Vec::with_capacity(stat.cells.len());
    for c in &stat.cells {
        let p = &points[c.point];
        match p.results.get(&c.key) {
            Some(e) if e.mean.is_finite() && e.se.is_finite() && e.se >= 0.0 => est.push(*e),
            Some(_) => {
                return undecided(
                    stat,
                    used,
                    level,
                    f64::NAN,
                    format!("{}: {} has no interval yet", p.label, c.key),
                )
            }
            None => {
                let why = p
                    .missing
                    .clone()
                    .unwrap_or_else(|| "not measured yet".into());
                return undecided(
                    stat,
                    used,
                    level,
                    f64::NAN,
                    format!("{}: no {} ({why})", p.label, c.key),
                );
            }
        }
    }
    let means: Vec<f64> = est.iter().map(|e| e.mean).collect();
    let at_means = stat.sample(&means);
    if !at_means.value.is_finite() {
        return undecided(
            stat,
            used,
            level,
            f64::NAN,
            format!("the {} cannot be computed at the means", stat.what),
        );
    }
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut values = Vec::with_capacity(DRAWS);
    let mut steps: Vec<Vec<f64>> = vec![Vec::with_capacity(DRAWS); at_means.steps.len()];
    let mut x = vec![0.0; est.len()];
    for _ in 0..DRAWS {
        for (xi, e) in x.iter_mut().zip(&est) {
            *xi = draw_t(e, &mut rng);
        }
        let s = stat.sample(&x);
        if s.value.is_finite() {
            values.push(s.value);
            for (k, v) in s.steps.iter().enumerate() {
                steps[k].push(*v);
            }
        }
    }
    if values.len() * 2 < DRAWS {
        return undecided(
            stat,
            used,
            level,
            at_means.value,
            format!(
                "the {} could be computed in {} of {DRAWS} draws only",
                stat.what,
                values.len()
            ),
        );
    }
    let tail = 0.5 * (1.0 - level);
    values.sort_by(f64::total_cmp);
    let (lo, hi) = (quantile(&values, tail), quantile(&values, 1.0 - tail));
    let mut decision = match stat.side {
        Side::Below(t) if hi < t => Decision::Supported,
        Side::Below(t) if lo > t => Decision::Contradicted,
        Side::Above(t) if lo > t => Decision::Supported,
        Side::Above(t) if hi < t => Decision::Contradicted,
        Side::Within(a, b) if lo > a && hi < b => Decision::Supported,
        Side::Within(a, b) if hi < a || lo > b => Decision::Contradicted,
        Side::Outside(a, b) if hi < a || lo > b => Decision::Supported,
        Side::Outside(a, b) if lo > a && hi < b => Decision::Contradicted,
        _ => Decision::Undecided,
    };
    let mut note = String::new();
    // A monotonic trend is refuted by one step that goes significantly the other way.
    for (k, s) in steps.iter_mut().enumerate() {
        s.retain(|v| v.is_finite());
        s.sort_by(f64::total_cmp);
        if quantile(s, 1.0 - tail) < 0.0 {
            decision = Decision::Contradicted;
            note = format!(
                "step {}→{} goes significantly against the trend",
                k + 1,
                k + 2
            );
            break;
        }
    }
    // Each result's share of the variance: (∂value/∂result · se)², by central differences.
    let mut by_point: Vec<(usize, f64)> = Vec::new();
    for (k, e) in est.iter().enumerate() {
        let mut up = means.clone();
        let mut down = means.clone();
        up[k] += e.se;
        down[k] -= e.se;
        let g = 0.5 * (stat.sample(&up).value - stat.sample(&down).value);
        let v = if g.is_finite() { g * g } else { 0.0 };
        let p = stat.cells[k].point;
        match by_point.iter_mut().find(|(q, _)| *q == p) {
            Some((_, acc)) => *acc += v,
            None => by_point.push((p, v)),
        }
    }
    Verdict {
        decision,
        value: at_means.value,
        lo,
        hi,
        level,
        side: stat.side.clone(),
        what: stat.what.clone(),
        points: used,
        note,
        variance_by_point: by_point,
    }
}
