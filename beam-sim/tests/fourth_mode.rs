//! A beam with a fourth mode (clamped, about 190 Hz at no payload), which the observer laws'
//! two-mode observer does not model and their root gauge sees: their loop rings through the
//! gauge, the torque swinging from limit to limit every tick or two. Checked for both
//! observer laws on the shipped table, a 90 deg move at the shortest time: the ring is caught
//! once the move's reference is at rest (`ringing`, told apart from a failed gauge), the
//! drive holds on its own law with the torque quiet, and the beam settles. On the three-mode
//! beam the same move latches nothing.

mod common;

use beam_sim::commanded::{run_commands, CommandedRun, Step};
use beam_sim::metrics::SettleSpec;
use beam_sim::sensors::SensorConfig;
use beam_wire::command::Command;
use model_core::{BeamParams, FaultFlags, LawKind, Mode};

const TARGET_RAD: f64 = core::f64::consts::FRAC_PI_2;
const RUN_S: f64 = 3.0;

fn run<const N: usize>(kind: LawKind) -> CommandedRun {
    let script = [
        Step::Send(Command::MoveTo {
            to_rad: TARGET_RAD as f32,
            time_s: None,
        }),
        Step::Wait(RUN_S),
    ];
    run_commands::<N>(
        BeamParams::aluminium(),
        common::shipped(),
        0.0,
        kind,
        0.0,
        &script,
        SensorConfig::default(),
    )
    .unwrap_or_else(|e| panic!("{kind:?}, {N} modes: {e}"))
}

#[test]
fn an_observer_laws_ring_on_a_fourth_mode_is_caught_at_rest_and_the_beam_settles() {
    // The drive's limit is the plant's (10 N m).
    let limit = BeamParams::aluminium().torque_limit_nm as f32;
    for kind in [LawKind::SmcModal, LawKind::Lqg] {
        let r = run::<4>(kind);
        let end = r.move_ends()[0];
        // It rang: the torque at the limit, both ways, while the reference moved.
        let moving: Vec<f32> = r
            .ticks
            .iter()
            .filter(|k| k.t < end)
            .map(|k| k.torque_nm)
            .collect();
        assert!(
            moving.iter().any(|&u| u >= limit) && moving.iter().any(|&u| u <= -limit),
            "{kind:?}: no ring to catch"
        );
        // Caught within 20 ms of the reference coming to rest, as ringing, not as the
        // gauge; not a stop.
        let caught = r
            .ticks
            .iter()
            .find(|k| k.faults.contains(FaultFlags::RINGING))
            .unwrap_or_else(|| panic!("{kind:?}: never caught"));
        assert!(
            caught.t >= end - 1e-9 && caught.t <= end + 0.02,
            "{kind:?}: caught at {} s, the move ended at {end} s",
            caught.t
        );
        let last = r.ticks.last().unwrap();
        assert_eq!(last.faults, FaultFlags::RINGING, "{kind:?}");
        assert_eq!(last.faults.to_string(), "ringing");
        assert_eq!(last.mode, Mode::Holding, "{kind:?}");
        // Quiet on the drive's own law: a tenth of the limit at most, 0.1 s after the catch.
        let after = r
            .ticks
            .iter()
            .filter(|k| k.t > caught.t + 0.1)
            .map(|k| k.torque_nm.abs())
            .fold(0.0f32, f32::max);
        assert!(after < 0.1 * limit, "{kind:?}: {after} N m after the catch");
        // And the beam settles (0.05 deg, 5 ue), where it rang for good before.
        let settle = r.settle_s(
            r.exchanges[0].t,
            RUN_S + 1.0,
            TARGET_RAD,
            &SettleSpec::default(),
        );
        assert!(
            settle.is_some_and(|s| s < 2.0),
            "{kind:?}: settle {settle:?} s"
        );
    }
}

#[test]
fn the_same_move_on_three_modes_latches_nothing() {
    for kind in [LawKind::SmcModal, LawKind::Lqg] {
        let r = run::<3>(kind);
        assert!(
            r.ticks.iter().all(|k| k.faults.is_empty()),
            "{kind:?}: {}",
            r.ticks.last().unwrap().faults
        );
    }
}
