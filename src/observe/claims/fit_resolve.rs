//! Resolving a `fit` claim: the points it fits (Janda or Beverloo over the silo's orifices, a
//! line or proportion through chute results or parameters) and the fitted parameter it tests.

use super::data::{result_key, select};
use super::scope::{
    at_text, check_block, check_param, check_result, unresolved, Scope, Unresolved,
};
use super::spec::{Fit, FitModel};
use super::statistic::{Cell, Kind, Side, Statistic, XOf};

pub(super) fn fit(t: &Fit, cx: &Scope) -> Result<Statistic, Unresolved> {
    let Scope {
        path,
        points,
        results,
        scene,
        silo,
    } = *cx;
    let f = format!("{path}.fit");
    check_param(t.model, &t.parameter, &format!("{f}.parameter"))?;
    let side = Side::of(&t.bound()).ok_or_else(|| {
        unresolved(
            &f,
            "expected exactly one of below, above, within, outside".into(),
        )
    })?;
    let chosen: Vec<usize> = select(points, &t.at)
        .into_iter()
        .filter(|&i| !points[i].clogged)
        .collect();
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
                    "the Beverloo law needs the particle diameter, bulk density and gravity".into(),
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
            check_block(yn, t.block, &f)?;
            check_block(xn, t.block, &f)?;
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
