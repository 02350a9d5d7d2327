//! `sweep schema`: the JSON Schema of campaign files, with the silo parameters under `base`.

pub fn run() -> anyhow::Result<i32> {
    let mut campaign = serde_json::to_value(schemars::schema_for!(sweep::campaign::CampaignFile))?;
    let mut silo = serde_json::to_value(schemars::schema_for!(sweep::scene::SiloParams))?;
    if let Some(o) = silo.as_object_mut() {
        o.remove("$schema");
        o.remove("required");
    }
    if let Some(props) = campaign.pointer_mut("/properties") {
        props["base"] = silo;
    }
    println!("{}", serde_json::to_string_pretty(&campaign)?);
    Ok(0)
}
