#!/usr/bin/env python3
"""Basilisk's dynamics alone on the test bed's default simulation scenario: simulated seconds
per wall second, as JSON on stdout.

The baseline of `pipeline_speed`, whose target is to be "faster than Basilisk's dynamics alone on the same
scenario (Basilisk 2.12 from PyPI: `bsk` wheels + hub, 0.01 s step, 3 wheels with friction)".

What is simulated (the test bed's defaults, docs/parameters.md and the manoeuvre's defaults):
- a rigid hub (`spacecraft.Spacecraft`): 350 kg, inertia [[45.2, 0.3, -0.2], [0.3, 46.1, 0.4],
  [-0.2, 0.4, 62.7]] kg m² about its centre of mass (the bearing's centre: no gravity torque,
  and no gravity effector at all: the hub's translation is integrated but stays at rest);
- a `reactionWheelStateEffector` with three balanced wheels on body X, Y, Z: Js = 1.5915e-3
  kg m² (1 Nms at 6000 rpm), |u| <= 0.1 Nm, 6000 rpm, Coulomb friction 1.5e-3 Nm and viscous
  friction 3.0e-6 Nm/(rad/s) (Basilisk's `useRWfriction`, no Stribeck term), at rest at t = 0;
- the initial attitude heading 20°, pitch 5°, roll 5° (a 3-2-1 rotation of the level frame,
  as `attitude::from_heading_pitch_roll`), at rest;
- torque commands: a constant `ArrayMotorTorqueMsg` of [+0.004, -0.003, +0.0025] Nm (above the
  Coulomb friction, so the wheels spin up and friction acts throughout, below 6000 rpm in 300 s)
  written once before the run. No flight software (no navigation, no attitude control) runs: "dynamics alone".
- one task at 0.01 s; the spacecraft integrates with Basilisk's default RK4 (the test bed's
  plant also integrates RK4 substeps of 0.01 s), no message recorders.

Timing: the wall time of `ExecuteSimulation()` only (not the set-up or the import).

    python3 bench/basilisk_speed.py [--duration 300] [--repeats 3]
"""

import argparse
import json
import statistics
import sys
import time


def build(duration_s):
    from Basilisk.architecture import messaging
    from Basilisk.simulation import reactionWheelStateEffector, spacecraft
    from Basilisk.utilities import (
        RigidBodyKinematics as rbk,
        SimulationBaseClass,
        macros,
        simIncludeRW,
    )

    sim = SimulationBaseClass.SimBaseClass()
    process = sim.CreateNewProcess("dynamics")
    process.addTask(sim.CreateNewTask("dynamics_task", macros.sec2nano(0.01)))

    sc = spacecraft.Spacecraft()
    sc.ModelTag = "testbed"
    sc.hub.mHub = 350.0
    sc.hub.r_BcB_B = [[0.0], [0.0], [0.0]]
    sc.hub.IHubPntBc_B = [[45.2, 0.3, -0.2], [0.3, 46.1, 0.4], [-0.2, 0.4, 62.7]]
    deg = 3.141592653589793 / 180.0
    sc.hub.sigma_BNInit = [[x] for x in rbk.euler3212MRP([20.0 * deg, 5.0 * deg, 5.0 * deg])]
    sc.hub.omega_BN_BInit = [[0.0], [0.0], [0.0]]

    factory = simIncludeRW.rwFactory()
    for axis in ([1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]):
        factory.create(
            "custom",
            axis,
            Js=1.5915e-3,
            Omega=0.0,
            Omega_max=6000.0,
            u_max=0.1,
            useMaxTorque=True,
            useRWfriction=True,
            fCoulomb=1.5e-3,
            cViscous=3.0e-6,
            RWModel=messaging.BalancedWheels,
        )
    wheels = reactionWheelStateEffector.ReactionWheelStateEffector()
    wheels.ModelTag = "wheels"
    factory.addToSpacecraft("wheels", wheels, sc)

    command = messaging.ArrayMotorTorqueMsgPayload()
    command.motorTorque = [0.004, -0.003, 0.0025]
    command_msg = messaging.ArrayMotorTorqueMsg().write(command)
    wheels.rwMotorCmdInMsg.subscribeTo(command_msg)

    sim.AddModelToTask("dynamics_task", wheels, 2)
    sim.AddModelToTask("dynamics_task", sc, 1)
    sim.InitializeSimulation()
    sim.ConfigureStopTime(macros.sec2nano(duration_s))
    # Keep the message objects alive as long as the simulation.
    return sim, sc, wheels, command_msg


def run_once(duration_s):
    sim, sc, wheels, _keep = build(duration_s)
    start = time.perf_counter()
    sim.ExecuteSimulation()
    wall = time.perf_counter() - start
    state = sc.scStateOutMsg.read()
    speeds = wheels.rwSpeedOutMsg.read().wheelSpeeds[:3]
    return wall, list(state.omega_BN_B), list(speeds)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--duration", type=float, default=300.0, help="simulated seconds")
    parser.add_argument("--repeats", type=int, default=3, help="runs (the median is reported)")
    args = parser.parse_args()
    try:
        import Basilisk  # noqa: F401
        from importlib.metadata import version

        bsk_version = version("bsk")
    except Exception as error:  # not installed: say so in the JSON
        print(json.dumps({"installed": False, "error": str(error)}))
        return 0
    walls = []
    for _ in range(max(1, args.repeats)):
        wall, rate, speeds = run_once(args.duration)
        walls.append(wall)
    wall = statistics.median(walls)
    print(
        json.dumps(
            {
                "installed": True,
                "bsk_version": bsk_version,
                "simulated_s": args.duration,
                "step_s": 0.01,
                "repeats": len(walls),
                "wall_s": walls,
                "x_real_time": args.duration / wall,
                "final_body_rate_rad_s": rate,
                "final_wheel_speed_rad_s": speeds,
            }
        )
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
