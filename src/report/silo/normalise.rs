//! Flow rates divided by the flow rate at a reference rotation frequency (Figs. 4 and 5 of
//! the silo paper): the reference choice, the ratios and their propagated 95 % CIs, as data and
//! tables. No database access and no plotting here.

use std::fmt::Write as _;

use crate::pooled::silo::{distinct, same_value, CloggedPoint, FlowPoint};
use crate::report::table::{csv_num, fixed, mm, sci, short, Table};

/// Q/Q_ref vs f for one orifice.
pub(crate) struct NormalisedCurve {
    /// Orifice diameter D, m.
    pub d_m: f64,
    /// Particle diameter d, m.
    pub particle_d_m: f64,
    /// (point, Q/Q_ref, half-width of its 95 % CI)
    pub points: Vec<(FlowPoint, f64, Option<f64>)>,
}

/// Flow rates divided by Q at the reference frequency, per orifice.
pub(crate) struct Normalised {
    /// The reference frequency, Hz.
    pub f_ref: f64,
    /// Whether f_ref is 1 Hz (the paper's choice) rather than the largest f present.
    pub is_one_hz: bool,
    /// One curve per orifice that has a reference point, by increasing D.
    pub curves: Vec<NormalisedCurve>,
    /// Orifices with no done job at f_ref, which cannot be normalised.
    pub skipped_d_m: Vec<f64>,
}

/// Normalises by Q at f = 1 Hz, or at the largest f present when 1 Hz is absent. The relative
/// CIs of Q and Q_ref add in quadrature; at f_ref itself the ratio is 1 by construction, so its
/// error bar is 0 rather than √2 times the relative CI.
pub(crate) fn normalise(points: &[FlowPoint]) -> Normalised {
    let fs = distinct(points.iter().map(|p| p.f_hz));
    let is_one_hz = fs.iter().any(|&f| same_value(f, 1.0));
    let f_ref = if is_one_hz {
        1.0
    } else {
        fs.last().copied().unwrap_or(1.0)
    };
    let mut curves = Vec::new();
    let mut skipped_d_m = Vec::new();
    for d in distinct(points.iter().map(|p| p.d_m)) {
        let at_d: Vec<&FlowPoint> = points.iter().filter(|p| same_value(p.d_m, d)).collect();
        let Some(reference) = at_d
            .iter()
            .find(|p| same_value(p.f_hz, f_ref))
            .filter(|p| p.q != 0.0)
        else {
            skipped_d_m.push(d);
            continue;
        };
        let rel_ref = reference.ci.map(|c| c / reference.q);
        let pts = at_d
            .iter()
            .map(|p| {
                let ratio = p.q / reference.q;
                let err = if same_value(p.f_hz, f_ref) {
                    Some(0.0)
                } else {
                    p.ci.zip(rel_ref)
                        .map(|(c, r)| ratio.abs() * ((c / p.q).powi(2) + r * r).sqrt())
                };
                ((*p).clone(), ratio, err)
            })
            .collect();
        curves.push(NormalisedCurve {
            d_m: d,
            particle_d_m: reference.particle_d_m,
            points: pts,
        });
    }
    Normalised {
        f_ref,
        is_one_hz,
        curves,
        skipped_d_m,
    }
}

impl Normalised {
    /// The y-axis label, naming the reference.
    pub fn y_label(&self) -> String {
        if self.is_one_hz {
            "Q / Q(f = 1 Hz)".into()
        } else {
            format!("Q / Q(f = {} Hz), largest f", short(self.f_ref))
        }
    }

    /// What the ratios are relative to, how their errors were obtained, and what was skipped.
    pub fn note(&self) -> String {
        let mut s = if self.is_one_hz {
            "Q normalised by Q at f = 1 Hz of the same D".to_string()
        } else {
            format!(
                "f = 1 Hz is not in the campaign: Q normalised by Q at the largest f present, {} Hz",
                short(self.f_ref)
            )
        };
        s.push_str("; err95 = ratio * sqrt((ci/Q)^2 + (ci_ref/Q_ref)^2), 0 at the reference\n");
        if !self.skipped_d_m.is_empty() {
            let ds: Vec<String> = self.skipped_d_m.iter().map(|&d| mm(d)).collect();
            let _ = writeln!(
                s,
                "no done job at the reference f for D = {} mm: not drawn",
                ds.join(", ")
            );
        }
        s
    }

    /// The text table and the CSV of `curves`.
    /// The text table and the CSV of `curves`, and of the `clogged` points (every run clogged:
    /// no Q), which the CSV lists with empty values and their runs, as the figures mark them.
    pub fn tables<'a>(
        &self,
        curves: impl Iterator<Item = &'a NormalisedCurve>,
        clogged: &[&CloggedPoint],
    ) -> (Table, Table) {
        let mut text = Table::new(&[
            "D_mm",
            "D/d",
            "f_Hz",
            "Q_kg/s",
            "ci95_kg/s",
            "Q/Q_ref",
            "err95",
            "replicas",
            "ci95_from",
        ]);
        let mut csv = Table::new(&[
            "orifice_diameter_m",
            "particle_diameter_m",
            "rotation_frequency_hz",
            "q_kg_per_s",
            "q_ci95_kg_per_s",
            "reference_frequency_hz",
            "q_over_q_ref",
            "q_over_q_ref_ci95",
            "replicas",
            "q_ci95_source",
            "clogged_runs",
        ]);
        for c in curves {
            for (p, ratio, err) in &c.points {
                text.push(vec![
                    mm(c.d_m),
                    fixed(Some(c.d_m / c.particle_d_m), 2),
                    short(p.f_hz),
                    sci(Some(p.q), 4),
                    sci(p.ci, 2),
                    fixed(Some(*ratio), 4),
                    fixed(*err, 4),
                    p.replicas.to_string(),
                    p.ci_source.name().into(),
                ]);
                csv.push(vec![
                    csv_num(Some(c.d_m)),
                    csv_num(Some(c.particle_d_m)),
                    csv_num(Some(p.f_hz)),
                    csv_num(Some(p.q)),
                    csv_num(p.ci),
                    csv_num(Some(self.f_ref)),
                    csv_num(Some(*ratio)),
                    csv_num(*err),
                    p.replicas.to_string(),
                    p.ci_source.name().into(),
                    p.clogged_replicas.to_string(),
                ]);
            }
        }
        for c in clogged {
            csv.push(vec![
                csv_num(Some(c.d_m)),
                csv_num(Some(c.particle_d_m)),
                csv_num(Some(c.f_hz)),
                String::new(),
                String::new(),
                csv_num(Some(self.f_ref)),
                String::new(),
                String::new(),
                "0".into(),
                String::new(),
                c.runs.to_string(),
            ]);
        }
        (text, csv)
    }
}
