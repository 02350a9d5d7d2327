//! What the chute figures share: the showcase cases, colours, the text's preface and the
//! figure captions.

use std::fmt::Write as _;

use anyhow::Result;
use rusqlite::Connection;

use crate::observe::chute::FlowState;
use crate::pooled::chute::replicas_of;
use crate::pooled::chute_jobs::{closest_job, done_without_summary, left_out_chute_jobs, ChuteJob};
use crate::pooled::silo::spread;
use crate::report::campaign::CampaignRef;
use crate::report::plot::{Axis, Panel};
use crate::report::table::short;

/// The paper's showcase cases (ξ, α in degrees): Figs. 2, 5 and 7 (a) and (b).
pub(crate) const SHOWCASES: [(f64, f64); 2] = [(1.3, 27.0), (2.5, 30.0)];
/// At most this many block curves per panel, spread over the bed, so the legend stays readable.
pub(crate) const MAX_BLOCK_CURVES: usize = 8;
/// Palette index of the grey used for references (Gaussian, power laws, fits).
pub(crate) const GREY: usize = 7;

/// Palette index of the i-th data series, skipping the reference grey.
pub(crate) fn color(i: usize) -> usize {
    if i % 9 >= GREY {
        i % 9 + 1
    } else {
        i % 9
    }
}

/// "ξ = 1.3, α = 27°"
pub(crate) fn case_name(job: &ChuteJob) -> String {
    format!(
        "ξ = {}, α = {}°{}",
        short(job.aspect_ratio),
        short(job.inclination_deg),
        if job.steady { "" } else { " (NOT steady)" }
    )
}

/// The showcase jobs present, without repeats (one when both cases pick the same job).
pub(crate) fn showcase_jobs(jobs: &[ChuteJob]) -> Vec<&ChuteJob> {
    let mut out: Vec<&ChuteJob> = Vec::new();
    for (xi, alpha) in SHOWCASES {
        if let Some(j) = closest_job(jobs, xi, alpha) {
            if out.iter().all(|o| o.job_id != j.job_id) {
                out.push(j);
            }
        }
    }
    out
}

/// Text naming the showcase jobs that a figure draws and, for a point with replicas among
/// `jobs`, that the curves are this one replica's.
pub(crate) fn showcase_note(shown: &[&ChuteJob], jobs: &[ChuteJob]) -> String {
    let mut text = String::from(
        "showcase jobs (the job with xi closest to 1.3 then alpha closest to 27 deg; \
         xi closest to 2.5 then alpha closest to 30 deg):",
    );
    if shown.is_empty() {
        text.push_str(" none\n");
    }
    for j in shown {
        let _ = write!(
            text,
            "\n  xi = {}, alpha = {} deg: job '{}'",
            short(j.aspect_ratio),
            short(j.inclination_deg),
            j.label
        );
        let n = replicas_of(jobs, j).len();
        if n > 1 {
            let _ = write!(
                text,
                " (1 of its point's {n} replicas: its curves; block values over replicas in \
                 fig3/fig4/fig6 and the skewness of fig5)"
            );
        }
    }
    if !shown.is_empty() {
        text.push('\n');
    }
    text
}

/// Notes every chute figure starts with: done jobs without a summary (not drawn) and jobs whose
/// flow was not steady (left out: drifted while measured, not steady by steady_max_time_s, or
/// not flowing).
pub(crate) fn preface(
    conn: &Connection,
    campaign: &CampaignRef,
    jobs: &[ChuteJob],
) -> Result<String> {
    let unsteady = jobs.iter().filter(|j| !j.steady).count();
    let running_on: Vec<String> = jobs
        .iter()
        .filter_map(|j| {
            let to = j.running_on_to_s?;
            Some(format!(
                "{} (job {}, to {} s)",
                j.label,
                j.job_id,
                short(to)
            ))
        })
        .collect();
    let mut text = format!(
        "{} {}job(s) drawn{}\n",
        jobs.len(),
        if running_on.is_empty() { "done " } else { "" },
        if unsteady > 0 {
            format!(", {unsteady} of them NOT steady (--include-unsteady), marked")
        } else {
            String::new()
        }
    );
    if !running_on.is_empty() {
        let _ = writeln!(
            text,
            "{} of them from their earlier end while a round runs them on: {}",
            running_on.len(),
            running_on.join("; ")
        );
    }
    let orphans = done_without_summary(conn, campaign.id)?;
    if !orphans.is_empty() {
        let _ = writeln!(
            text,
            "{} done job(s) without a chute_summary row, not drawn: {}",
            orphans.len(),
            orphans.join("; ")
        );
    }
    let left = left_out_chute_jobs(conn, campaign.id)?;
    if !left.is_empty() {
        let list: Vec<String> = left
            .iter()
            .map(|j| {
                let words = FlowState::parse(&j.state).map_or(j.state.as_str(), |f| f.words());
                let measured = if j.measured { "" } else { ", nothing measured" };
                format!("{} ({words}{measured})", j.label)
            })
            .collect();
        let _ = writeln!(
            text,
            "{} done job(s) not steady{}: {}",
            left.len(),
            if unsteady > 0 {
                ", those measured drawn and marked"
            } else {
                ", left out of the figure"
            },
            list.join("; ")
        );
    }
    Ok(text)
}

/// The figure's caption with how many of the `drawn` jobs a round runs on (drawn from their
/// earlier end) and, when jobs were left out as not steady, how many.
pub(crate) fn caption(
    conn: &Connection,
    campaign: &CampaignRef,
    drawn: &[ChuteJob],
    title: String,
) -> Result<String> {
    let running_on = drawn.iter().filter(|j| j.running_on_to_s.is_some()).count();
    let title = if running_on > 0 {
        format!("{title} — {running_on} job(s) from an earlier end, run on by a round")
    } else {
        title
    };
    let left = left_out_chute_jobs(conn, campaign.id)?;
    if left.is_empty() {
        return Ok(title);
    }
    let count = |s: FlowState| left.iter().filter(|j| j.state == s.as_str()).count();
    let parts: Vec<String> = [
        FlowState::Drifted,
        FlowState::NotSteady,
        FlowState::NotFlowing,
        FlowState::Layered,
    ]
    .into_iter()
    .filter(|&s| count(s) > 0)
    .map(|s| format!("{} {}", count(s), s.words()))
    .collect();
    Ok(format!("{title} — left out: {}", parts.join(", ")))
}

/// A panel that only says why it is empty.
pub(crate) fn empty_panel(x: Axis, y: Axis, why: &str) -> Panel {
    let mut p = Panel::new(x, y);
    p.title = Some(why.to_string());
    p
}

/// Indices of up to [`MAX_BLOCK_CURVES`] of `n` curves, spread evenly, both ends kept.
pub(crate) fn shown_indices(n: usize) -> Vec<usize> {
    spread(&(0..n).collect::<Vec<usize>>(), MAX_BLOCK_CURVES)
}

/// The chute's two-panel figures (fig1b, orientation, dy): the panels side by side under the
/// campaign's caption (`caption`), written as `name`, the summary table after `text`.
#[allow(clippy::too_many_arguments)]
pub(crate) fn two_panel_figure(
    conn: &Connection,
    campaign: &CampaignRef,
    drawn: &[ChuteJob],
    title: String,
    panels: Vec<crate::report::plot::Panel>,
    panel_size: (u32, u32),
    mut text: String,
    table: &crate::report::table::Table,
    csv: &crate::report::table::Table,
    out_dir: &crate::report::drawn::Output,
    name: &str,
) -> Result<crate::report::drawn::Drawn> {
    let fig = crate::report::plot::Figure {
        title: Some(caption(conn, campaign, drawn, title)?),
        panels,
        columns: 2,
        panel_size,
    };
    text.push_str(&table.to_text());
    Ok(crate::report::drawn::Drawn {
        text,
        files: crate::report::drawn::write_all(&fig, csv, out_dir, name)?,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn colors_skip_the_reference_grey() {
        let c: Vec<usize> = (0..10).map(color).collect();
        assert_eq!(c, vec![0, 1, 2, 3, 4, 5, 6, 8, 9, 0]);
    }
}
