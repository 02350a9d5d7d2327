//! `report --figure all`: every figure of a campaign's scene drawn into one directory, and an
//! `index.html` that shows each PNG with its table, links its SVG and CSV, and says why a
//! figure could not be drawn (a campaign without fields has no fig6; only an accuracy campaign
//! has `accuracy`). Nothing is left out silently.

use std::fmt::Write as _;
use std::path::PathBuf;

use anyhow::{Context, Result};
use rusqlite::Connection;

use super::campaign::find_campaign;
use super::drawn::Output;
use super::render::{figures_of, render_figure_with, FigureReport};
use super::table::escape;

/// What `--figure all` drew.
#[derive(Debug)]
pub struct AllFigures {
    /// The campaign drawn.
    pub campaign: String,
    /// Per figure of the scene: its name and what drawing it gave (the error as text).
    pub figures: Vec<(String, Result<FigureReport, String>)>,
    /// The index page.
    pub index: PathBuf,
}

/// Draws every figure of the campaign's scene into `out` and writes `out/index.html`. A figure
/// that cannot be drawn is listed with its reason; it does not stop the others.
///
/// # Errors
/// An unknown campaign, a scene without figures, or a file that cannot be written.
pub fn render_all(conn: &Connection, campaign: Option<&str>, out: &Output) -> Result<AllFigures> {
    let c = find_campaign(conn, campaign, None)?;
    let figures = figures_of(&c.scene)
        .with_context(|| format!("sweep draws no figures for scene '{}'", c.scene))?;
    std::fs::create_dir_all(&out.dir)
        .with_context(|| format!("creating output directory {}", out.dir.display()))?;
    let mut drawn = Vec::new();
    for (name, _) in figures {
        let qualified = format!("{}:{name}", c.scene);
        let r =
            render_figure_with(conn, &qualified, Some(&c.name), out).map_err(|e| format!("{e:#}"));
        drawn.push((name.to_string(), r));
    }
    let claims = super::claims::stored_claims(conn, c.id, &c.scene)?
        .map(|(scale, rows, _)| super::claims::claims_html(&scale, &rows));
    let index = out.dir.join("index.html");
    let page = index_html(&c.name, &c.scene, figures, &drawn, claims.as_deref());
    std::fs::write(&index, page).with_context(|| format!("writing {}", index.display()))?;
    Ok(AllFigures {
        campaign: c.name,
        figures: drawn,
        index,
    })
}

/// The file name of `path` (figures link their files relative to the index).
fn file_name(path: &std::path::Path) -> String {
    path.file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default()
}

fn index_html(
    campaign: &str,
    scene: &str,
    figures: &[(&str, &str)],
    drawn: &[(String, Result<FigureReport, String>)],
    claims: Option<&str>,
) -> String {
    let mut h = String::new();
    let _ = write!(
        h,
        "<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\"><title>{c}: figures</title>\n\
         <style>body{{font-family:sans-serif;max-width:1800px;margin:auto}}\
         img{{max-width:100%;border:1px solid #ccc}}pre{{background:#f6f6f6;padding:8px;\
         overflow-x:auto;font-size:13px}}.failed{{color:#a00}}</style></head><body>\n\
         <h1>Campaign {c} ({s})</h1>\n<p>Every figure of the {s} scene, drawn from the \
         database by <code>sweep report --figure all</code>.</p>\n<ul>\n",
        c = escape(campaign),
        s = escape(scene)
    );
    for (name, what) in figures {
        let _ = writeln!(
            h,
            "<li><a href=\"#{n}\">{n}</a>: {w}</li>",
            n = escape(name),
            w = escape(what)
        );
    }
    if claims.is_some() {
        h.push_str(
            "<li><a href=\"#claims\">claims</a>: the paper's statements and their verdicts</li>\n",
        );
    }
    h.push_str("</ul>\n");
    if let Some(c) = claims {
        h.push_str(c);
    }
    for ((name, what), (_, result)) in figures.iter().zip(drawn) {
        let _ = writeln!(
            h,
            "<h2 id=\"{n}\">{n}: {w}</h2>",
            n = escape(name),
            w = escape(what)
        );
        match result {
            Ok(r) => {
                let files: Vec<String> = r.files.iter().map(|f| file_name(f)).collect();
                if let Some(png) = files.iter().find(|f| f.ends_with(".png")) {
                    let _ = writeln!(h, "<img src=\"{}\" alt=\"{}\">", escape(png), escape(name));
                }
                let links: Vec<String> = files
                    .iter()
                    .map(|f| format!("<a href=\"{0}\">{0}</a>", escape(f)))
                    .collect();
                let _ = writeln!(h, "<p>{}</p>", links.join(" · "));
                let _ = writeln!(h, "<pre>{}</pre>", escape(&r.table));
            }
            Err(e) => {
                let _ = writeln!(h, "<p class=\"failed\">not drawn: {}</p>", escape(e));
            }
        }
    }
    h.push_str("</body></html>\n");
    h
}
