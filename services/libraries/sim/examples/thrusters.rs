//! The thruster shows in the in-process closed loop, printed:
//! `cargo run --release -p testbed-sim --example thrusters [-- DURATION_S]`.

use anyhow::Context;
use testbed_sim::thruster_shows::{
    momentum_dumping_scenario, rate_damping_scenario, run_and_summarise,
};

fn main() -> anyhow::Result<()> {
    let duration_s: f64 = match std::env::args().nth(1) {
        Some(s) => s.parse().with_context(|| format!("duration {s:?}"))?,
        None => 7200.0,
    };
    for thrusters in [false, true] {
        let scenario = momentum_dumping_scenario(thrusters, duration_s, 1);
        let (_, _, summary) =
            run_and_summarise(&scenario, 100.0, 0.01).context("momentum dumping run")?;
        println!(
            "momentum run, constant disturbance {:?} Nm, thrusters {}:",
            testbed_sim::thruster_shows::DUMP_DISTURBANCE_NM,
            if thrusters { "on (dumping)" } else { "off" }
        );
        print!("{summary}");
    }
    let rate = [2.0 / 3f64.sqrt(), -2.0 / 3f64.sqrt(), 2.0 / 3f64.sqrt()];
    let scenario = rate_damping_scenario(rate, 300.0, 1);
    let (_, _, summary) = run_and_summarise(&scenario, 0.0, 0.01).context("rate damping run")?;
    println!("rate damping on the thrusters alone from {rate:.4?} °/s (|w| = 2 °/s):");
    print!("{summary}");
    Ok(())
}
