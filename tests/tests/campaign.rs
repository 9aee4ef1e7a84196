//! `testbed campaign` end to end: a campaign run reproduced through the processes gives the
//! campaign's estimates bit for bit, shards merged give a single host's results byte for byte,
//! and a bad campaign is refused before anything runs.

use std::path::{Path, PathBuf};
use std::process::Command;
use testbed_campaign::{CampaignFile, Plan};
use testbed_config::RunConfig;
use testbed_e2e::{
    Scratch, assert_estimates_equal_the_in_process_loop, binary, logged_estimates, testbed_run,
    workspace_root,
};
use testbed_log::RunLog;
use testbed_sim::closed_loop;

fn worked_campaign() -> PathBuf {
    workspace_root().join("campaigns/paper-dispersed.toml")
}

/// What `testbed campaign ARGS` did.
fn campaign_output(args: &[&str]) -> std::process::Output {
    Command::new(binary("testbed"))
        .arg("campaign")
        .args(args)
        .output()
        .expect("running testbed campaign")
}

/// `testbed campaign ARGS`, which must succeed; its stdout.
fn campaign(args: &[&str]) -> String {
    let out = campaign_output(args);
    assert!(
        out.status.success(),
        "testbed campaign {args:?} failed ({}):\n{}",
        out.status,
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).into_owned()
}

#[test]
fn a_campaign_run_reproduced_in_lockstep_gives_the_campaigns_estimates_bit_for_bit() {
    let scratch = Scratch::new("campaign-reproduce");
    let log = scratch.path().join("run.mcap");
    let file = worked_campaign();
    let index = 3;
    // 25 simulated s: the first 25 s of run 3, through every process of the simulation profile.
    testbed_run(&[
        "--campaign",
        file.to_str().unwrap(),
        "--campaign-run",
        &index.to_string(),
        "--duration",
        "25",
        "--log",
        log.to_str().unwrap(),
    ]);

    // Run 3 as the campaign generates it, on the in-process loop.
    let plan = Plan::new(CampaignFile::load(&file).unwrap(), RunConfig::default()).unwrap();
    let mut expected = plan.job(index, "base").unwrap().config;
    expected.run.duration_s = 25.0;
    let run_log = RunLog::open(&log).unwrap();
    let logged = RunConfig::from_toml_str(run_log.config_toml(), "log").unwrap();
    // The processes ran the campaign's configuration: same model, controller, estimator,
    // manoeuvre and seed (the run section also names the profile, log and participants).
    assert_eq!(logged.model, expected.model);
    assert_eq!(logged.controller, expected.controller);
    assert_eq!(logged.estimator, expected.estimator);
    assert_eq!(logged.manoeuvre, expected.manoeuvre);
    assert_eq!(logged.run.seed, expected.run.seed);
    assert_eq!(logged.run.duration_s, 25.0);
    let trace = closed_loop::run(&closed_loop::Scenario::from_run(&expected)).unwrap();
    assert_estimates_equal_the_in_process_loop(&logged_estimates(&run_log), &trace);
}

/// The worked campaign cut to 12 runs of 40 s, with two variants.
fn small_campaign(dir: &Path) -> PathBuf {
    let text = std::fs::read_to_string(worked_campaign())
        .unwrap()
        .replace("runs = 200", "runs = 12")
        .replace("run.duration_s = 150.0", "run.duration_s = 40.0");
    let text = format!(
        "{text}\n[variants.with]\ncontroller.pd_friction.friction_compensation = true\n\
         [variants.without]\ncontroller.pd_friction.friction_compensation = false\n"
    );
    let path = dir.join("small.toml");
    std::fs::write(&path, text).unwrap();
    path
}

#[test]
fn shards_merged_give_the_single_hosts_results_byte_for_byte() {
    let scratch = Scratch::new("campaign-shards");
    let file = small_campaign(scratch.path());
    let file = file.to_str().unwrap();
    let dir = |name: &str| scratch.path().join(name).to_str().unwrap().to_string();
    let stdout = campaign(&[
        file,
        "--out",
        &dir("single"),
        "--workers",
        "2",
        "--no-progress",
    ]);
    assert!(
        stdout.contains("without against with over 12 paired runs"),
        "{stdout}"
    );
    for shard in 0..3 {
        let spec = format!("{shard}/3");
        campaign(&[
            file,
            "--shard",
            &spec,
            "--workers",
            "1",
            "--out",
            &dir(&format!("shard{shard}")),
        ]);
    }
    // Shards in any order.
    campaign(&[
        "merge",
        &dir("shard2"),
        &dir("shard0"),
        &dir("shard1"),
        "--out",
        &dir("merged"),
    ]);
    for name in [
        "runs.csv",
        "runs.json",
        "series.csv",
        "summary.json",
        "manifest.json",
        "campaign.toml",
    ] {
        let single = std::fs::read(scratch.path().join("single").join(name)).unwrap();
        let merged = std::fs::read(scratch.path().join("merged").join(name)).unwrap();
        assert!(
            single == merged,
            "{name} of the merge differs from the single host's"
        );
    }
    let runs = std::fs::read_to_string(scratch.path().join("single/runs.csv")).unwrap();
    assert_eq!(
        runs.lines().count(),
        1 + 12 * 2,
        "a header and a row per run and variant"
    );
    let shard = std::fs::read_to_string(scratch.path().join("shard1/runs.csv")).unwrap();
    assert_eq!(shard.lines().count(), 1 + 4 * 2);
    for figure in [
        "report.md",
        "ecdf.svg",
        "ecdf.png",
        "envelope.svg",
        "envelope.png",
    ] {
        assert!(
            scratch.path().join("merged").join(figure).is_file(),
            "{figure}"
        );
    }

    // A shard missing from the merge is named.
    let out = campaign_output(&[
        "merge",
        &dir("shard0"),
        &dir("shard1"),
        "--out",
        &dir("partial"),
    ]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && stderr.contains("runs missing") && stderr.contains("2 (with)"),
        "{stderr}"
    );
}

#[test]
fn a_bad_campaign_is_refused_before_anything_runs() {
    let scratch = Scratch::new("campaign-refused");
    let path = scratch.path().join("bad.toml");
    std::fs::write(
        &path,
        "[campaign]\nruns = 5\nseed = 1\n[dispersions]\n\"manoeuvre.initial_pich_deg\" = { uniform = { low = -1.0, high = 1.0 } }\n",
    )
    .unwrap();
    let out_dir = scratch.path().join("out");
    let out = campaign_output(&[path.to_str().unwrap(), "--out", out_dir.to_str().unwrap()]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert!(
        stderr.contains("bad.toml")
            && stderr.contains("`manoeuvre.initial_pich_deg`")
            && stderr.contains("initial_pitch_deg"),
        "{stderr}"
    );
    assert!(!out_dir.exists(), "nothing written");
}
