//! `sweep schema`: the JSON Schema of campaign files, both scenes (`campaign::campaign_schema`).

pub fn run() -> anyhow::Result<i32> {
    let schema = sweep::campaign::campaign_schema();
    println!("{}", serde_json::to_string_pretty(&schema)?);
    Ok(0)
}
