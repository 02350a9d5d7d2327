//! The one entry point the CLI calls: pick the campaign, draw the named figure into a
//! directory, and say which of the campaign's jobs the figure still lacks.

use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
use rusqlite::Connection;

use super::campaign::find_campaign;
use super::missing::campaign_completion;
use super::silo;

/// The figures [`render_figure`] knows, with what they show.
pub const FIGURES: [(&str, &str); 4] = [
    ("fig2", "silo: discharged mass M(t) per (D, f)"),
    ("fig3", "silo: Q vs D per f with Janda fits, and D_min vs f"),
    ("fig4", "silo: Q / Q(f = 1 Hz) vs f per D"),
    (
        "fig5",
        "silo: Q / Q(f = 1 Hz) vs f, one panel per large D (D/d > 4.5)",
    ),
];

/// What drawing one figure produced.
#[derive(Debug, Clone)]
pub struct FigureReport {
    /// Plain-text summary for the terminal: fixed-width columns, units in the headers.
    pub table: String,
    /// Files written: `<figure>.svg`, `<figure>.png`, `<figure>.csv`.
    pub files: Vec<PathBuf>,
    /// Labels (campaign_jobs.label) of the campaign's jobs whose status is not 'done'.
    pub missing: Vec<String>,
}

/// Draws `figure` ("fig2".."fig5") from the rows of `campaign` (by name; None = the most recent
/// silo campaign) into `out_dir`, which is created if needed. Jobs that are not done are listed
/// in [`FigureReport::missing`]; the figure is drawn from those that are.
///
/// # Errors
/// For an unknown figure (the message lists the known ones), an unknown campaign, a campaign of
/// another scene, a database error, or a file that cannot be written.
pub fn render_figure(
    conn: &Connection,
    figure: &str,
    campaign: Option<&str>,
    out_dir: &Path,
) -> Result<FigureReport> {
    let draw = match figure {
        "fig2" => silo::fig2,
        "fig3" => silo::fig3,
        "fig4" => silo::fig4,
        "fig5" => silo::fig5,
        _ => {
            let known: Vec<String> = FIGURES
                .iter()
                .map(|(n, what)| format!("{n} ({what})"))
                .collect();
            bail!(
                "unknown figure '{figure}': known figures are {}",
                known.join(", ")
            )
        }
    };
    let campaign = find_campaign(conn, campaign, "silo")?;
    std::fs::create_dir_all(out_dir)
        .with_context(|| format!("creating output directory {}", out_dir.display()))?;
    let completion = campaign_completion(conn, campaign.id)?;
    let drawn = draw(conn, &campaign, out_dir)?;
    let mut table = format!("{figure}: campaign '{}'\n{}", campaign.name, drawn.text);
    if !completion.missing.is_empty() {
        table.push_str(&format!(
            "{} of {} jobs not done (listed as missing): drawn from the done ones only\n",
            completion.missing.len(),
            completion.total
        ));
    }
    Ok(FigureReport {
        table,
        files: drawn.files,
        missing: completion.missing,
    })
}
