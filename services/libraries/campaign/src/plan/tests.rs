use super::*;
use std::path::Path;

fn plan(text: &str) -> Result<Plan, CampaignError> {
    let file = CampaignFile::parse(text, Path::new("c.toml"))?;
    Plan::new(file, RunConfig::default())
}

fn refused(body: &str) -> String {
    plan(&format!("[campaign]\nruns = 4\nseed = 9\n{body}"))
        .unwrap_err()
        .to_string()
}

const DISPERSED: &str = "[campaign]\nruns = 8\nseed = 9\n[base]\nrun.duration_s = 5.0\n\
    [dispersions]\n\"manoeuvre.initial_pitch_deg\" = { uniform = { low = -5.0, high = 5.0 } }\n\
    \"model.gyro.bias_deg_s[0]\" = { normal = { mean = 0.0, std = 1e-3 }, apply = \"add\" }\n\
    \"model.wheels.coulomb_nm[2]\" = { normal = { mean = 1.0, std = 0.2 }, apply = \"scale\" }\n";

#[test]
fn an_unknown_parameter_is_refused_with_its_file_and_key() {
    let err =
        refused("[dispersions]\n\"model.platform.mass\" = { uniform = { low = 1, high = 2 } }\n");
    assert!(
        err.contains("c.toml") && err.contains("`model.platform.mass`") && err.contains("mass_kg"),
        "{err}"
    );
    let err = refused("[dispersions]\n\"model.gyro.bias_deg_s[3]\" = { values = [0.0] }\n");
    assert!(
        err.contains("`model.gyro.bias_deg_s[3]`") && err.contains("3 elements"),
        "{err}"
    );
    // An optional table that is absent must be given first, and the message says so.
    let err = refused("[dispersions]\n\"model.effects.com_offset.r_m[0]\" = { values = [0.0] }\n");
    assert!(
        err.contains("no key `com_offset`") && err.contains("[base]"),
        "{err}"
    );
}

#[test]
fn a_key_that_is_not_a_number_is_refused() {
    let err = refused(
        "[dispersions]\n\"controller.pd_friction.friction_compensation\" = { values = [0.0, 1.0] }\n",
    );
    assert!(
        err.contains("`controller.pd_friction.friction_compensation`")
            && err.contains("not a number"),
        "{err}"
    );
    let err = refused("[dispersions]\n\"model.platform\" = { values = [1.0] }\n");
    assert!(
        err.contains("table") && err.contains("not a number"),
        "{err}"
    );
    let err = refused("[dispersions]\n\"run.seed\" = { values = [1, 2] }\n");
    assert!(
        err.contains("`run.seed`") && err.contains("campaign's to set"),
        "{err}"
    );
    // A whole-number key takes whole numbers only.
    let err = refused(
        "[dispersions]\n\"estimator.mekf.max_update_iterations\" = { uniform = { low = 1, high = 4 } }\n",
    );
    assert!(err.contains("whole number"), "{err}");
    plan("[campaign]\nruns = 2\nseed = 1\n[dispersions]\n\"estimator.mekf.max_update_iterations\" = { values = [1, 4] }\n")
        .expect("a list of whole numbers");
}

#[test]
fn a_value_the_run_configuration_refuses_is_refused_before_any_run() {
    let err = refused("[dispersions]\n\"run.duration_s\" = { values = [10.0, -1.0] }\n");
    assert!(
        err.contains("`run.duration_s`") && err.contains("-1") && err.contains("must be > 0"),
        "{err}"
    );
    let err = refused(
        "[dispersions]\n\"controller.pd_friction.p_nm[0]\" = { normal = { mean = 1.0, std = 0.1 }, apply = \"scale\" }\n\
         \"model.platform.inertia_kgm2[0][1]\" = { uniform = { low = 0.0, high = 1e6 } }\n",
    );
    // The low end already makes the inertia asymmetric.
    assert!(
        err.contains("`model.platform.inertia_kgm2[0][1]`")
            && err.contains("the value 0")
            && err.contains("symmetric"),
        "{err}"
    );
    // A variant whose value the configuration refuses: an unknown key (a law's name that
    // does not exist reads the same way: the key and the value refused) or a bad value.
    for (variant, key) in [
        ("controller.law = \"nope\"", "law"),
        ("controller.law = \"nope\"", "nope"),
        ("run.duration_s = -2.0", "run.duration_s"),
    ] {
        let err = refused(&format!("[variants.a]\n[variants.b]\n{variant}\n"));
        assert!(
            err.contains("c.toml") && err.contains("variant `b`") && err.contains(key),
            "{err}"
        );
    }
    let err = refused("[base]\nrun.duration_s = 0.0\n");
    assert!(
        err.contains("base run configuration") && err.contains("run.duration_s"),
        "{err}"
    );
}

#[test]
fn a_variant_may_not_set_a_dispersed_key_or_the_seed() {
    let err = refused(
        "[dispersions]\n\"controller.pd_friction.d_nms[1]\" = { values = [10.0, 20.0] }\n\
         [variants.a]\n[variants.b]\ncontroller.pd_friction.d_nms = [1.0, 1.0, 1.0]\n",
    );
    assert!(
        err.contains("variant `b`") && err.contains("controller.pd_friction.d_nms[1]"),
        "{err}"
    );
    let err = refused("[variants.a]\nrun.seed = 3\n[variants.b]\n");
    assert!(
        err.contains("variant `a`") && err.contains("device seed"),
        "{err}"
    );
}

#[test]
fn each_run_is_determined_by_the_campaign_seed_and_its_index() {
    let other = plan(&DISPERSED.replace("seed = 9", "seed = 10")).unwrap();
    let plan = plan(DISPERSED).unwrap();
    let a = plan.job(3, BASE_VARIANT).unwrap();
    let again = plan.job(3, BASE_VARIANT).unwrap();
    assert_eq!(a.spec, again.spec);
    assert_eq!(a.config, again.config);
    let b = plan.job(4, BASE_VARIANT).unwrap();
    assert_ne!(a.spec.seed, b.spec.seed);
    assert!(
        a.spec
            .values
            .iter()
            .zip(&b.spec.values)
            .all(|(x, y)| x != y)
    );
    // The draws are where their keys say, applied to the nominal.
    let nominal = RunConfig::default();
    assert_eq!(a.config.run.seed, a.spec.seed);
    assert_eq!(a.config.run.duration_s, 5.0);
    assert_eq!(a.config.manoeuvre.initial_pitch_deg, a.spec.values[0]);
    assert!((-5.0..=5.0).contains(&a.spec.values[0]));
    assert_eq!(a.config.model.gyro.bias_deg_s[0], a.spec.values[1]);
    assert!((a.spec.values[1] - nominal.model.gyro.bias_deg_s[0]).abs() < 5e-3);
    assert_eq!(a.config.model.wheels.coulomb_nm[2], a.spec.values[2]);
    assert_ne!(
        a.config.model.wheels.coulomb_nm[2],
        nominal.model.wheels.coulomb_nm[2]
    );
    // The estimator keeps the nominal model's bias: the truth is dispersed, not its belief.
    let mut written = nominal.estimator.clone();
    written.write_out(&nominal.model).unwrap();
    assert_eq!(a.config.estimator, written);
    assert!(
        plan.job(8, BASE_VARIANT)
            .unwrap_err()
            .to_string()
            .contains("runs 0 to 7")
    );
    // A campaign with another seed draws other runs.
    assert_ne!(other.draws(3), plan.draws(3));
}

#[test]
fn variants_share_the_runs_draws_and_differ_in_their_keys() {
    let text = format!(
        "{DISPERSED}[variants.with]\ncontroller.pd_friction.friction_compensation = true\n\
         [variants.without]\ncontroller.pd_friction.friction_compensation = false\n"
    );
    let plan = plan(&text).unwrap();
    let jobs = plan.prepare(&[0, 5]).unwrap();
    let order: Vec<(u64, &str)> = jobs
        .iter()
        .map(|j| (j.spec.index, j.spec.variant.as_str()))
        .collect();
    assert_eq!(
        order,
        [(0, "with"), (0, "without"), (5, "with"), (5, "without")]
    );
    assert_eq!(jobs[0].spec.values, jobs[1].spec.values);
    assert_eq!(jobs[0].spec.seed, jobs[1].spec.seed);
    let compensates = |job: &Job| {
        job.config
            .controller
            .law_params::<testbed_flight::control::PdFrictionConfig>()
            .unwrap()
            .friction_compensation
    };
    assert!(compensates(&jobs[0]));
    assert!(!compensates(&jobs[1]));
    let err = plan.job(0, "neither").unwrap_err().to_string();
    assert!(
        err.contains("no variant `neither`") && err.contains("with, without"),
        "{err}"
    );
}

#[test]
fn a_draw_the_configuration_refuses_names_the_run_and_its_values() {
    // A wide normal on a friction that must be >= 0: some run draws a negative one.
    let plan = plan(
        "[campaign]\nruns = 64\nseed = 1\n[dispersions]\n\
         \"model.wheels.coulomb_nm[0]\" = { normal = { mean = 1.0, std = 3.0 }, apply = \"scale\" }\n",
    )
    .unwrap();
    let err = plan
        .prepare(&(0..64).collect::<Vec<_>>())
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("c.toml: run ") && err.contains("model.wheels.coulomb_nm[0] = -"),
        "{err}"
    );
}

#[test]
fn shards_split_the_runs_by_index() {
    let all: Vec<u64> = (0..3).flat_map(|i| shard_indices(10, i, 3)).collect();
    let mut sorted = all.clone();
    sorted.sort_unstable();
    assert_eq!(sorted, (0..10).collect::<Vec<_>>());
    assert_eq!(shard_indices(10, 1, 3), [1, 4, 7]);
    assert_eq!(parse_shard("2/4"), Ok((2, 4)));
    for bad in ["4/4", "1", "a/2", "0/0"] {
        assert!(parse_shard(bad).is_err(), "{bad}");
    }
}
