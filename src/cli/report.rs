//! `sweep report --figure figN`.

use std::path::PathBuf;

use super::DbArg;

#[derive(clap::Args)]
pub struct Arguments {
    /// A figure of the campaign's scene: silo fig2..fig5, chute fig2..fig7 (or scene:figN).
    #[arg(long)]
    pub figure: String,
    /// Campaign name (default: the most recent campaign; its scene picks the figure set).
    #[arg(long)]
    pub campaign: Option<String>,
    /// Output directory.
    #[arg(long, default_value = "figures")]
    pub out: PathBuf,
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
    let conn = sweep::store::open(&a.db.db)?;
    std::fs::create_dir_all(&a.out)?;
    let r = sweep::report::render_figure(&conn, &a.figure, a.campaign.as_deref(), &a.out)?;
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
