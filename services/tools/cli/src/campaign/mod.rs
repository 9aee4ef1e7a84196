//! `testbed campaign FILE`: N runs of a scenario with dispersions on the in-process closed loop,
//! across the cores, reduced to a report; `testbed campaign merge DIR...` joins the results of
//! shards into the same report. The campaign itself (file, draws, metrics, statistics, merge)
//! is `testbed_campaign`; here: the command line, the progress bar and the files.

mod figures;
mod report;

use anyhow::{Context, Result, bail};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::io::IsTerminal as _;
use std::path::{Path, PathBuf};
use std::time::Instant;
use testbed_campaign::plan::{parse_shard, shard_indices};
use testbed_campaign::results::{self, Manifest, files};
use testbed_campaign::{CampaignFile, Plan, execute};
use testbed_config::RunConfig;

#[derive(Debug, clap::Args)]
#[command(args_conflicts_with_subcommands = true, subcommand_negates_reqs = true)]
pub struct CampaignArgs {
    #[command(subcommand)]
    pub action: Option<CampaignAction>,
    /// The campaign file (TOML: runs, seed, base configuration, dispersions, variants; see
    /// docs/campaigns.md).
    #[arg(required = true, value_name = "FILE")]
    pub file: Option<PathBuf>,
    /// Directory of the results and the report [default: out/campaign-<file stem>/, with
    /// -shard-<i>-of-<N> for a shard].
    #[arg(long, value_name = "DIR")]
    pub out: Option<PathBuf>,
    /// Runs carried out at once, one per thread [default: every core].
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..))]
    pub workers: Option<u32>,
    /// Carry out one slice of the runs: the indices k with k mod N = i (0 <= i < N); `testbed
    /// campaign merge` joins the slices' directories.
    #[arg(long, value_name = "i/N", value_parser = parse_shard)]
    pub shard: Option<(u64, u64)>,
    /// Check the campaign (every run's configuration) and say what would run; run nothing.
    #[arg(long)]
    pub check: bool,
    /// No progress bar.
    #[arg(long)]
    pub no_progress: bool,
}

#[derive(Debug, clap::Subcommand)]
pub enum CampaignAction {
    /// Join the results directories of a campaign's shards into one report (the same files a
    /// single host writes).
    Merge(MergeArgs),
}

#[derive(Debug, clap::Args)]
pub struct MergeArgs {
    /// The shards' results directories.
    #[arg(required = true, value_name = "DIR")]
    pub dirs: Vec<PathBuf>,
    /// Directory of the merged results [default: out/campaign-<file stem>/].
    #[arg(long, value_name = "DIR")]
    pub out: Option<PathBuf>,
}

pub fn run(args: &CampaignArgs) -> Result<()> {
    match (&args.action, &args.file) {
        (Some(CampaignAction::Merge(merge_args)), _) => merge(merge_args),
        (None, Some(file)) => run_campaign(args, file),
        (None, None) => bail!("give a campaign file, or `merge DIR...`"),
    }
}

/// The campaign of `path`, checked against its base run configuration.
pub fn load_plan(path: &Path) -> Result<Plan> {
    let file = CampaignFile::load(path)?;
    let base = match &file.config {
        Some(config) => RunConfig::load(config)
            .with_context(|| format!("campaign {}: its config", path.display()))?,
        None => RunConfig::default(),
    };
    Ok(Plan::new(file, base)?)
}

/// `out/campaign-<stem>` beside the working directory.
fn default_out(campaign: &Path, shard: Option<(u64, u64)>) -> PathBuf {
    let stem = campaign
        .file_stem()
        .map_or_else(|| "campaign".into(), |s| s.to_string_lossy().into_owned());
    let name = match shard {
        Some((i, n)) => format!("campaign-{stem}-shard-{i}-of-{n}"),
        None => format!("campaign-{stem}"),
    };
    PathBuf::from("out").join(name)
}

fn run_campaign(args: &CampaignArgs, path: &Path) -> Result<()> {
    let plan = load_plan(path)?;
    let file = &plan.file;
    let indices = match args.shard {
        Some((i, n)) => shard_indices(file.runs, i, n),
        None => (0..file.runs).collect(),
    };
    let workers = args.workers.map_or_else(
        || std::thread::available_parallelism().map_or(1, |n| n.get()),
        |n| n as usize,
    );
    // Every run's configuration is checked before the first one starts.
    let jobs = plan.prepare(&indices)?;
    let out = args
        .out
        .clone()
        .unwrap_or_else(|| default_out(path, args.shard));
    let variants = file.variant_names();
    let what = format!(
        "campaign {}: {} run(s){} × {} variant(s) ({}), {} dispersion(s), {} simulated s each, on {workers} worker(s)",
        path.display(),
        indices.len(),
        args.shard.map_or_else(String::new, |(i, n)| format!(
            " (shard {i}/{n} of {})",
            file.runs
        )),
        variants.len(),
        variants.join(", "),
        file.dispersions.len(),
        jobs.first().map_or(0.0, |j| j.config.run.duration_s),
    );
    if args.check {
        println!(
            "{what}: every run's configuration is valid; results would go to {}",
            out.display()
        );
        return Ok(());
    }
    eprintln!("{what}");
    let bar = (!args.no_progress && std::io::stderr().is_terminal()).then(|| {
        let bar =
            ProgressBar::with_draw_target(Some(jobs.len() as u64), ProgressDrawTarget::stderr());
        if let Ok(style) = ProgressStyle::with_template(
            "{elapsed:>4} [{bar:30}] {pos}/{len} runs, {per_sec}, {eta} left",
        ) {
            bar.set_style(style.progress_chars("=> "));
        }
        bar
    });
    let started = Instant::now();
    let done = || {
        if let Some(bar) = &bar {
            bar.inc(1);
        }
    };
    let rows = execute::run_jobs(&jobs, &file.metrics, workers, &done)?;
    let wall_s = started.elapsed().as_secs_f64();
    if let Some(bar) = bar {
        bar.finish_and_clear();
    }
    let manifest = Manifest {
        campaign: path.display().to_string(),
        fingerprint: plan.fingerprint(),
        runs: file.runs,
        shard: args.shard.map(|(i, n)| format!("{i}/{n}")),
        runs_here: indices.len() as u64,
    };
    let summary = report::write(&out, file, &manifest, &rows)?;
    report::print(&summary, &out, Some((wall_s, rows.len(), workers)));
    Ok(())
}

fn merge(args: &MergeArgs) -> Result<()> {
    let mut parts = Vec::new();
    let mut campaign: Option<CampaignFile> = None;
    for dir in &args.dirs {
        let read = |name: &str| {
            let path = dir.join(name);
            std::fs::read_to_string(&path).with_context(|| format!("reading {}", path.display()))
        };
        let manifest: Manifest = serde_json::from_str(&read(files::MANIFEST_JSON)?)
            .with_context(|| format!("{}: {}", dir.display(), files::MANIFEST_JSON))?;
        let file = CampaignFile::parse(&read(files::CAMPAIGN_TOML)?, Path::new(&manifest.campaign))
            .with_context(|| format!("{}: {}", dir.display(), files::CAMPAIGN_TOML))?;
        let rows = results::read_rows(
            &dir.display().to_string(),
            &file.keys(),
            &read(files::RUNS_CSV)?,
            &read(files::SERIES_CSV)?,
        )?;
        campaign.get_or_insert(file);
        parts.push((manifest, rows));
    }
    let file = campaign.context("no results directories given")?;
    let first = parts[0].0.clone();
    let rows = results::merge(parts, &file.variant_names())?;
    let manifest = Manifest {
        shard: None,
        runs_here: first.runs,
        ..first
    };
    let out = args
        .out
        .clone()
        .unwrap_or_else(|| default_out(&file.path, None));
    let summary = report::write(&out, &file, &manifest, &rows)?;
    report::print(&summary, &out, None);
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{Cli, Command};
    use clap::Parser;

    fn parse(line: &str) -> Result<Cli, clap::Error> {
        Cli::try_parse_from(line.split_whitespace())
    }

    #[test]
    fn the_command_lines_of_a_campaign_parse() {
        let Command::Campaign(args) = parse("testbed campaign c.toml --shard 1/4 --workers 2")
            .unwrap()
            .command
        else {
            panic!("not a campaign");
        };
        assert_eq!(args.file, Some(PathBuf::from("c.toml")));
        assert_eq!((args.shard, args.workers), (Some((1, 4)), Some(2)));
        let Command::Campaign(args) = parse("testbed campaign merge a b --out m").unwrap().command
        else {
            panic!("not a campaign");
        };
        let Some(CampaignAction::Merge(merge)) = args.action else {
            panic!("not a merge");
        };
        assert_eq!(merge.dirs, [PathBuf::from("a"), PathBuf::from("b")]);
        for bad in [
            "testbed campaign",
            "testbed campaign c.toml --shard 4/4",
            "testbed campaign c.toml --workers 0",
            "testbed campaign merge",
            "testbed run --campaign c.toml",
            "testbed run --campaign-run 3",
            "testbed run --campaign c.toml --campaign-run 3 --seed 4",
            "testbed run --campaign c.toml --campaign-run 3 --config r.toml",
        ] {
            assert!(parse(bad).is_err(), "{bad} should not parse");
        }
        let Command::Run(run) = parse(
            "testbed run --campaign c.toml --campaign-run 3 --campaign-variant b --duration 20",
        )
        .unwrap()
        .command
        else {
            panic!("not a run");
        };
        assert_eq!(run.campaign_run, Some(3));
        assert_eq!(run.campaign_variant.as_deref(), Some("b"));
    }

    fn worked(name: &str) -> PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../../../campaigns")
            .join(name)
    }

    #[test]
    fn the_worked_campaigns_load_and_every_run_is_valid() {
        let plan = load_plan(&worked("friction-compensation.toml")).unwrap();
        assert_eq!(plan.file.variant_names(), ["compensated", "uncompensated"]);
        let all: Vec<u64> = (0..plan.file.runs).collect();
        assert_eq!(plan.prepare(&all).unwrap().len(), 200);
        let path = worked("paper-dispersed.toml");
        let plan = load_plan(&path).unwrap();
        assert_eq!(plan.file.runs, 200);
        assert!(plan.file.dispersions.len() >= 10);
        let jobs = plan
            .prepare(&(0..plan.file.runs).collect::<Vec<_>>())
            .unwrap();
        assert_eq!(jobs.len(), 200);
        assert!(jobs.iter().all(|j| j.config.run.duration_s == 150.0));
        assert_eq!(
            default_out(&path, Some((2, 8))),
            PathBuf::from("out/campaign-paper-dispersed-shard-2-of-8")
        );
    }
}
