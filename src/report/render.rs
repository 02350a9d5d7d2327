//! The one entry point the CLI calls: pick the campaign, pick the figure set from its scene,
//! draw the named figure into a directory, and say which of the campaign's jobs it still lacks.

use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
use rusqlite::Connection;

use super::accuracy;
use super::campaign::{find_campaign, CampaignRef};
use super::chute;
use super::drawn::{Drawn, Output};
use super::missing::campaign_completion;
use super::silo;
use super::silo::fields as silo_fields;

/// The silo paper's figures (PRE 2020), with what they show.
const SILO_FIGURES: [(&str, &str); 11] = [
    ("fig2", "discharged mass M(t) per (D, f)"),
    ("fig3", "Q vs D per f with Janda fits, and D_min vs f"),
    ("fig4", "Q / Q(f = 1 Hz) vs f per D"),
    (
        "fig5",
        "Q / Q(f = 1 Hz) vs f, one panel per large D (D/d > 4.5)",
    ),
    (
        "fig6",
        "solid fraction maps phi(r, z) at the map times, per f (largest D)",
    ),
    (
        "fig7",
        "speed maps |V|(r, z) with streamlines of (V_r, V_z) at the map times, per f",
    ),
    (
        "fig8",
        "azimuthal velocity maps V_theta(r, z) at the map times, per f",
    ),
    (
        "fig9",
        "<phi>, -<P_z>, -<V_z> across the orifice (z = 0) vs r/R, per f",
    ),
    (
        "fig10",
        "kinetic pressure maps p^k(r, z), rows D, columns f",
    ),
    (
        "fig11",
        "<p^k> in the orifice cylinder vs f per D, and normalised, 95 % CI",
    ),
    (
        "accuracy",
        "shift of Q ± 95 % CI (replicas pooled) vs wall time per numerical setting (accuracy campaign)",
    ),
];

/// The chute paper's figures (Soft Matter 2022), with what they show.
const CHUTE_FIGURES: [(&str, &str); 10] = [
    (
        "fig1b",
        "V_x(z) and phi(z) profiles per (xi, alpha) point, replicas combined with their spread",
    ),
    (
        "fig2",
        "MSD_z(tau) per block, log-log, for the xi~1.3 and xi~2.5 showcase jobs",
    ),
    (
        "fig3",
        "D/D_max and shear/shear_max vs z/L per alpha, at the xi closest to 1.3",
    ),
    (
        "fig4",
        "D/D_max and shear/shear_max vs z/L per alpha, at the xi closest to 2.5",
    ),
    (
        "fig5",
        "standardised v_z PDFs per block vs the Gaussian, and skewness vs z/L",
    ),
    (
        "fig6",
        "D/shear vs d_perp^2 and D vs shear d_perp^2 with linear fits, central bed",
    ),
    (
        "fig7",
        "C(r)/C(0) vs r/L per block, linear and log y with lines of slope -1/l",
    ),
    (
        "orientation",
        "rods' nematic order S2(z) and <|cos theta|>(z) to the flow per (xi, alpha) point",
    ),
    (
        "dy",
        "ESI: D_y/D_y,max beside shear/shear_max vs z/L, and D_y vs shear d_perp^2 (central bed)",
    ),
    (
        "accuracy",
        "shift of the bulk D ± 95 % CI (replicas pooled) vs wall time per numerical setting (accuracy campaign)",
    ),
];

/// The figures [`render_figure`] knows, per scene (campaigns.scene): (scene, [(figure, what)]).
pub const FIGURES: [(&str, &[(&str, &str)]); 2] =
    [("silo", &SILO_FIGURES), ("chute", &CHUTE_FIGURES)];

/// The figures of `scene`, or None for a scene without figures.
pub fn figures_of(scene: &str) -> Option<&'static [(&'static str, &'static str)]> {
    FIGURES.iter().find(|(s, _)| *s == scene).map(|(_, f)| *f)
}

type DrawFn = fn(&Connection, &CampaignRef, &Output) -> Result<Drawn>;

/// The function drawing `figure` of `scene`; every entry of [`FIGURES`] has one.
fn drawer(scene: &str, figure: &str) -> Option<DrawFn> {
    Some(match (scene, figure) {
        ("silo", "fig2") => silo::fig2,
        ("silo", "fig3") => silo::fig3,
        ("silo", "fig4") => silo::fig4,
        ("silo", "fig5") => silo::fig5,
        ("silo", "fig6") => silo_fields::fig6,
        ("silo", "fig7") => silo_fields::fig7,
        ("silo", "fig8") => silo_fields::fig8,
        ("silo", "fig9") => silo_fields::fig9,
        ("silo", "fig10") => silo_fields::fig10,
        ("silo", "fig11") => super::silo::orifice_pressure::fig11,
        ("chute", "fig1b") => chute::fig1b,
        ("chute", "fig2") => chute::fig2,
        ("chute", "fig3") => chute::fig3,
        ("chute", "fig4") => chute::fig4,
        ("chute", "fig5") => chute::fig5,
        ("chute", "fig6") => chute::fig6,
        ("chute", "fig7") => chute::fig7,
        ("chute", "orientation") => chute::orientation,
        ("chute", "dy") => chute::dy,
        ("silo" | "chute", "accuracy") => accuracy::accuracy,
        _ => return None,
    })
}

/// "fig2 (what), fig3 (what)" for one scene.
fn listing(figures: &[(&str, &str)]) -> String {
    let known: Vec<String> = figures
        .iter()
        .map(|(n, what)| format!("{n} ({what})"))
        .collect();
    known.join(", ")
}

/// The scenes that have a figure called `name`.
fn scenes_with(name: &str) -> Vec<&'static str> {
    FIGURES
        .iter()
        .filter(|(_, f)| f.iter().any(|(n, _)| *n == name))
        .map(|(s, _)| *s)
        .collect()
}

/// Splits "scene:figN" into (Some(scene), "figN") and "figN" into (None, "figN"), and checks
/// that some scene (or the named one) has that figure.
fn parse_figure(figure: &str) -> Result<(Option<&'static str>, &str)> {
    let Some((scene, name)) = figure.split_once(':') else {
        if scenes_with(figure).is_empty() {
            let all: Vec<String> = FIGURES
                .iter()
                .map(|(s, f)| format!("{s}: {}", listing(f)))
                .collect();
            bail!(
                "unknown figure '{figure}': known figures are {}",
                all.join("; ")
            )
        }
        return Ok((None, figure));
    };
    let Some((scene, figures)) = FIGURES.iter().find(|(s, _)| *s == scene) else {
        let scenes: Vec<&str> = FIGURES.iter().map(|(s, _)| *s).collect();
        bail!(
            "unknown scene '{scene}' in figure '{figure}': scenes with figures are {}",
            scenes.join(", ")
        )
    };
    if !figures.iter().any(|(n, _)| *n == name) {
        bail!(
            "unknown figure '{figure}': the {scene} figures are {}",
            listing(figures)
        )
    }
    Ok((Some(scene), name))
}

/// What drawing one figure produced.
#[derive(Debug, Clone)]
pub struct FigureReport {
    /// Plain-text summary for the terminal: fixed-width columns, units in the headers.
    pub table: String,
    /// Files written: `<figure>.svg`, `<figure>.png`, `<figure>.csv` for the silo figures,
    /// `chute_<figure>.*` for the chute figures (so both can share one output directory).
    pub files: Vec<PathBuf>,
    /// Labels (campaign_jobs.label) of the campaign's jobs whose status is not 'done'.
    pub missing: Vec<String>,
}

/// Draws `figure` from the rows of `campaign` into `out_dir`, which is created if needed.
///
/// The campaign is the one named, or when None the most recent campaign; its scene
/// (campaigns.scene) picks the figure set ([`FIGURES`]): "fig3" is the silo paper's Fig. 3 for a
/// silo campaign and the chute paper's Fig. 3 for a chute campaign. A figure may name its scene,
/// "silo:fig3"; then with no campaign the most recent campaign of that scene is used, and a named
/// campaign of another scene is an error. Jobs that are not done are listed in
/// [`FigureReport::missing`]; the figure is drawn from those that are.
///
/// # Errors
/// For a figure no scene has (the message lists them per scene), a figure the campaign's scene
/// does not have (the message lists that scene's figures), a scene-qualified figure asked of a
/// campaign of another scene, an unknown campaign, a database error, or a file that cannot be
/// written.
pub fn render_figure(
    conn: &Connection,
    figure: &str,
    campaign: Option<&str>,
    out_dir: &Path,
) -> Result<FigureReport> {
    render_figure_with(conn, figure, campaign, &Output::new(out_dir))
}

/// [`render_figure`] into `out`, which also says whether figures carry titles.
///
/// # Errors
/// As [`render_figure`].
pub fn render_figure_with(
    conn: &Connection,
    figure: &str,
    campaign: Option<&str>,
    out: &Output,
) -> Result<FigureReport> {
    let out_dir: &Path = out;
    let (asked_scene, name) = parse_figure(figure)?;
    let campaign = find_campaign(conn, campaign, asked_scene.filter(|_| campaign.is_none()))?;
    let scene = campaign.scene.as_str();
    if let Some(asked) = asked_scene.filter(|s| *s != scene) {
        let hint = match figures_of(scene) {
            Some(f) => format!(
                "ask for '{name}' alone to get its {scene} figure ({})",
                listing(f)
            ),
            None => format!("sweep draws no figures for scene '{scene}'"),
        };
        bail!(
            "'{figure}' is a {asked} figure but campaign '{}' is a '{scene}' campaign: pass a \
             {asked} campaign with --campaign, or {hint}",
            campaign.name
        )
    }
    let Some(draw) = drawer(scene, name) else {
        let Some(figures) = figures_of(scene) else {
            let scenes: Vec<&str> = FIGURES.iter().map(|(s, _)| *s).collect();
            bail!(
                "campaign '{}' has scene '{scene}', for which sweep draws no figures (figures \
                 exist for {})",
                campaign.name,
                scenes.join(", ")
            )
        };
        let others = scenes_with(name).join(" or ");
        bail!(
            "unknown figure '{name}' for campaign '{}' (scene '{scene}'): the {scene} figures are \
             {}; '{name}' is a {others} figure, pass such a campaign with --campaign",
            campaign.name,
            listing(figures)
        )
    };
    std::fs::create_dir_all(out_dir)
        .with_context(|| format!("creating output directory {}", out_dir.display()))?;
    let completion = campaign_completion(conn, campaign.id)?;
    let drawn = draw(conn, &campaign, out)?;
    let mut table = format!("{name}: campaign '{}'\n{}", campaign.name, drawn.text);
    if !completion.missing.is_empty() {
        table.push_str(&format!(
            "{} of {} jobs not done (listed as missing): drawn from the done ones, and from the \
             earlier end of a job a round runs on where the figure says so\n",
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_listed_figure_has_a_drawer_and_names_parse() {
        for (scene, figures) in FIGURES {
            for (name, _) in figures {
                assert!(drawer(scene, name).is_some(), "{scene}:{name}");
                assert_eq!(
                    parse_figure(&format!("{scene}:{name}")).expect("parse"),
                    (Some(scene), *name)
                );
            }
        }
        assert_eq!(parse_figure("fig6").expect("fig6"), (None, "fig6"));
        let msg = format!("{:#}", parse_figure("silo:fig12").expect_err("silo fig12"));
        assert!(msg.contains("the silo figures are fig2"), "{msg}");
        let msg = format!("{:#}", parse_figure("hopper:fig2").expect_err("scene"));
        assert!(msg.contains("silo, chute"), "{msg}");
    }
}
