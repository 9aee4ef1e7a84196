//! `testbed run --campaign FILE --campaign-run K`: run K of a campaign through the pipeline's
//! processes, with the configuration the campaign generated for it (draws and device seed), so
//! that the processes compute what the campaign's in-process run computed.

use super::RunArgs;
use anyhow::{Context, Result};
use testbed_campaign::file::BASE_VARIANT;
use testbed_config::RunConfig;

/// The run configuration of `--campaign-run` of `--campaign` (and `--campaign-variant`), when
/// given.
pub fn campaign_config(args: &RunArgs) -> Result<Option<RunConfig>> {
    let (Some(file), Some(index)) = (&args.campaign, args.campaign_run) else {
        return Ok(None);
    };
    let plan = crate::campaign::load_plan(file)?;
    let variant = match &args.campaign_variant {
        Some(v) => v.clone(),
        None if plan.file.variants.is_empty() => BASE_VARIANT.to_string(),
        None => anyhow::bail!(
            "campaign {} has the variants {}: name one with --campaign-variant",
            file.display(),
            plan.file.variant_names().join(", ")
        ),
    };
    let job = plan
        .job(index, &variant)
        .with_context(|| format!("--campaign-run {index}"))?;
    Ok(Some(job.config))
}
