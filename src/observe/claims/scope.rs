//! What every claim test's resolution shares: the refusal by field (`Unresolved`), the one
//! point an `at` picks, and the checks of results, fit parameters and blocks.

use super::data::{select, PointData, SceneConstants, CHUTE_BED_ONLY};
use super::spec::{At, FitModel};
use super::statistic::short;

/// Why a claim cannot be resolved against the points (a validation problem: the field and
/// what was expected).
#[derive(Clone, Debug, PartialEq)]
pub struct Unresolved {
    pub field: String,
    pub message: String,
}

pub(super) fn unresolved(field: &str, message: String) -> Unresolved {
    Unresolved {
        field: field.into(),
        message,
    }
}

/// The single point matching `at`, or why not.
pub(super) fn one_point(points: &[PointData], at: &At, field: &str) -> Result<usize, Unresolved> {
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

pub fn at_text(at: &At) -> String {
    if at.is_empty() {
        return "(any)".into();
    }
    at.iter()
        .map(|(k, v)| format!("{k}={}", short(*v)))
        .collect::<Vec<_>>()
        .join(", ")
}

pub(super) fn check_result(result: &str, known: &[&str], field: &str) -> Result<(), Unresolved> {
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

pub(super) fn check_param(model: FitModel, parameter: &str, field: &str) -> Result<(), Unresolved> {
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

/// What every test's resolution reads.
pub(super) struct Scope<'a> {
    pub(super) path: &'a str,
    pub(super) points: &'a [PointData],
    pub(super) results: &'a [&'a str],
    pub(super) scene: Option<SceneConstants>,
    pub(super) silo: bool,
}

/// A result given over the bed only (no block) is not read in a block.
pub(super) fn check_block(result: &str, block: Option<i64>, f: &str) -> Result<(), Unresolved> {
    if block.is_some() && CHUTE_BED_ONLY.contains(&result) {
        return Err(unresolved(
            &format!("{f}.block"),
            format!(
                "'{result}' is a value over part of the bed, not of one block; expected no block"
            ),
        ));
    }
    Ok(())
}
