//! `sweep report --figure figN` (or `all`: every figure of the campaign and an index page), and
//! `sweep report --claims` (the campaign's claims table).

use std::path::PathBuf;

use sweep::project::Project;

use super::DbArg;

#[derive(clap::Args)]
pub struct Arguments {
    /// A figure of the campaign's scene: silo fig2..fig11, chute fig2..fig7, accuracy (or
    /// scene:figN); `all` draws every figure of the scene and writes index.html beside them.
    #[arg(long, required_unless_present = "claims")]
    pub figure: Option<String>,
    /// The campaign's claims table (NAME.md and NAME.csv in --out, after the campaign): each
    /// claim with the paper's words, sweep's value and interval, the verdict, the scale and the
    /// cost.
    #[arg(long)]
    pub claims: bool,
    /// Campaign name (default: the most recent campaign; its scene picks the figure set).
    #[arg(long)]
    pub campaign: Option<String>,
    /// Output directory.
    #[arg(long, default_value = "figures")]
    pub out: PathBuf,
    /// Draw figures without their title line (a paper's caption replaces it).
    #[arg(long)]
    pub no_title: bool,
    /// Chute figures: draw also the jobs whose flow was not steady (drifted while measured, or
    /// measured with `measure_unsteady`), marked "not steady"; by default they are left out.
    #[arg(long)]
    pub include_unsteady: bool,
    #[command(flatten)]
    pub db: DbArg,
}

pub fn run(a: Arguments) -> anyhow::Result<i32> {
    if !a.db.db.exists() {
        eprintln!(
            "sweep: no database at {}: launch a campaign first",
            a.db.db.display()
        );
        return Ok(2);
    }
    let project = Project::open(&a.db.db)?;
    std::fs::create_dir_all(&a.out)?;
    let out = sweep::report::Output {
        dir: a.out.clone(),
        titles: !a.no_title,
        include_unsteady: a.include_unsteady,
    };
    if a.claims {
        let code = super::claims::report(&project, a.campaign.as_deref(), &a.out)?;
        if code != 0 || a.figure.is_none() {
            return Ok(code);
        }
    }
    let figure = a.figure.as_deref().unwrap_or("all");
    if figure == "all" {
        return run_all(&project, a.campaign.as_deref(), &out);
    }
    let r = sweep::report::render_figure_with(project.conn(), figure, a.campaign.as_deref(), &out)?;
    println!("{}", r.table);
    if !r.missing.is_empty() {
        println!(
            "incomplete: {} job(s) not done: {}",
            r.missing.len(),
            r.missing.join("; ")
        );
    }
    for f in &r.files {
        println!("wrote {}", f.display());
    }
    Ok(0)
}

/// `--figure all`: every figure of the campaign's scene and `index.html`. A figure the campaign
/// cannot give (fig6 without fields, `accuracy` of a study campaign) is listed with its reason,
/// here and in the index, and is not an error.
fn run_all(
    project: &Project,
    campaign: Option<&str>,
    out: &sweep::report::Output,
) -> anyhow::Result<i32> {
    let all = sweep::report::render_all(project.conn(), campaign, out)?;
    let mut failed = 0;
    for (name, r) in &all.figures {
        match r {
            Ok(r) => {
                let files: Vec<String> = r.files.iter().map(|f| f.display().to_string()).collect();
                println!("{name}: wrote {}", files.join(", "));
            }
            Err(e) => {
                failed += 1;
                println!("{name}: not drawn: {e}");
            }
        }
    }
    println!(
        "campaign '{}': {} of {} figures drawn; index: {}",
        all.campaign,
        all.figures.len() - failed,
        all.figures.len(),
        all.index.display()
    );
    Ok(0)
}
