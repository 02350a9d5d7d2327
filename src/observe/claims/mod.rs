//! Claims: a paper's statement as one test on a campaign's pooled results (`spec`), resolved
//! against its points (`resolve`) into a statistic (`statistic`, fits in `fit_value`), and decided by that statistic's interval
//! (`verdict`): supported, contradicted or undecided. Pure: the runner and the reports read the
//! store, build [`PointData`], and call this.

mod data;
mod fit_resolve;
mod fit_value;
mod forecast;
#[cfg(test)]
mod forecast_tests;
#[cfg(test)]
mod profile_tests;
mod resolve;
mod scope;
mod spec;
mod statistic;
#[cfg(test)]
mod tests;
mod verdict;

pub use data::{
    matches, result_key, same_value, select, Estimate, PointData, SceneConstants, CHUTE_BED_ONLY,
    CHUTE_RESULTS, SILO_RESULTS,
};
pub use forecast::work_to_decide;
pub use resolve::ALONG_BLOCKS;
pub use scope::{at_text, Unresolved};
pub use spec::{
    At, Bound, Claim, Compare, CompareAs, Direction, Fit, FitModel, MinimumInside, TestKind, Trend,
};
pub use statistic::{short, Side, Statistic};
pub use verdict::{decide, look_level, seed_of, spending_level, Decision, Verdict, ALPHA, DRAWS};
