//! Loads on a held hub: a constant torque (a tilted rig, a cable, a hand) pushes a hub that
//! the drive holds at rest. Every law holds 0.5 N m within 1 deg with the shipped rows (smc
//! and smc-strain through the drive's hold, `controller::HOLD_HANDOVER_RAD`) but the paper's
//! PD baseline, a spring of 20 N m/rad (1.43 deg), and
//! the laws with integral action hold 2 and 5 N m for ten minutes without a fault (a hub held
//! still under torque is not a stuck encoder); a truly stuck encoder still latches.

mod common;

use beam_sim::commanded::{CommandedRun, Step};
use beam_sim::sensors::SensorFault;
use beam_wire::command::{Command, Outcome};
use model_core::{FaultFlags, LawKind, Mode};

const DEG: f64 = core::f64::consts::PI / 180.0;

/// A move to 30 deg at payload `kg`, held; then `load_nm` on the hub for `hold_s`.
fn hold(kind: LawKind, kg: f32, load_nm: f64, hold_s: f64) -> Result<CommandedRun, String> {
    let script = [
        Step::Attach(kg as f64),
        Step::Send(Command::SetPayload { kg }),
        Step::Send(Command::MoveTo {
            to_rad: (30.0 * DEG) as f32,
            time_s: None,
        }),
        Step::UntilDone {
            settle_s: 1.0,
            max_s: 5.0,
        },
        Step::Load(load_nm),
        Step::Wait(hold_s),
    ];
    common::run_shipped(kind, &script)
}

/// The largest hub error from 30 deg over the last `s` seconds of `r`, deg, and the mode at
/// the end.
fn worst_over_last(r: &CommandedRun, s: f64) -> (f64, Mode) {
    let end = r.ticks.last().unwrap();
    let worst = r
        .ticks
        .iter()
        .filter(|k| k.t >= end.t - s)
        .map(|k| (k.theta / DEG - 30.0).abs())
        .fold(0.0, f64::max);
    (worst, end.mode)
}

#[test]
fn every_law_holds_half_a_newton_metre_within_a_degree_at_every_payload_row() {
    let mut rows = vec![];
    for &kind in LawKind::ALL.iter() {
        // At each payload the table has rows for (the PD baseline, with none, at 0).
        let table = common::shipped();
        let mut payloads: Vec<f32> = table
            .rows
            .iter()
            .filter(|r| r.law.kind() == kind)
            .map(|r| r.payload_kg)
            .collect();
        if payloads.is_empty() {
            payloads.push(0.0);
        }
        for kg in payloads {
            for load in [0.5, -0.5] {
                let line = match hold(kind, kg, load, 3.0) {
                    Ok(r) => {
                        let replies: Vec<Outcome> =
                            r.exchanges.iter().map(|e| e.reply.outcome).collect();
                        // Once the load's transient is over: the last 2 s.
                        let (worst, mode) = worst_over_last(&r, 2.0);
                        // The PD baseline is the paper's Kp 20 N m/rad, kept as the reference
                        // and calibration law: a spring, which a steady 0.5 N m deflects by
                        // 0.5 / 20 rad = 1.43 deg (Hooke), not within 1 deg. That is checked
                        // for it instead.
                        let bound = if kind == LawKind::Pd {
                            0.5 / model_core::PdGains::BASELINE.kp as f64 / DEG * 1.05
                        } else {
                            1.0
                        };
                        let ok = worst <= bound
                            && mode == Mode::Holding
                            && matches!(replies[1], Outcome::Moving { .. });
                        format!(
                            "{kind:>10} {kg:6.4} kg {load:+} N m: worst {worst:7.3} deg over the last 2 s, {mode:?}{}",
                            if ok { "" } else { "  FAILS" }
                        )
                    }
                    Err(e) => format!("{kind:>10} {kg:6.4} kg {load:+} N m: {e}  FAILS"),
                };
                rows.push(line);
            }
        }
    }
    let table = rows.join("\n");
    println!("{table}");
    assert!(!table.contains("FAILS"), "{table}");
}

#[test]
fn the_laws_with_integral_action_hold_two_and_five_newton_metres_for_ten_minutes() {
    // A hub held still under torque reads no counts for minutes: that is a hold, not a
    // stuck encoder, while the reference is at rest.
    let mut rows = vec![];
    for kind in [LawKind::SmcI, LawKind::Lqg, LawKind::SmcModal] {
        for load in [2.0, -5.0] {
            let line = match hold(kind, 0.0, load, 600.0) {
                Ok(r) => {
                    // Held: no fault, and the load never gains on the law: after the first
                    // 10 s the hub's error never grows by more than two counts of dither
                    // (0.044 deg; integral action only takes it back).
                    let (worst, mode) = worst_over_last(&r, 590.0);
                    let end = r.ticks.last().unwrap();
                    let err = |theta: f64| (theta / DEG - 30.0).abs();
                    let at_10 = err(r.theta_at(end.t - 590.0).unwrap());
                    let at_end = err(end.theta);
                    let faults = r.ticks.iter().any(|k| k.mode == Mode::Fault);
                    let ok = mode == Mode::Holding && !faults && worst <= at_10 + 0.05;
                    format!(
                        "{kind:>10} {load:+} N m for 600 s: {at_10:6.3} deg off after 10 s, at most {worst:6.3} after, {at_end:6.3} at 600 s, {mode:?}{}",
                        if ok { "" } else { "  FAILS" }
                    )
                }
                Err(e) => format!("{kind:>10} {load:+} N m: {e}  FAILS"),
            };
            rows.push(line);
        }
    }
    let table = rows.join("\n");
    println!("{table}");
    assert!(!table.contains("FAILS"), "{table}");
}

#[test]
fn a_stuck_encoder_still_latches_within_a_tenth_of_a_second_of_a_move() {
    // The encoder freezes 100 ms into a 45 deg move of 0.5 s: the reference moves on, the
    // counts do not, the torque pushes: ENCODER_STUCK, for every law. (In the PD baseline's
    // own shortest move, 0.14 s, its torque then whips the beam out of the model whatever
    // the drive does once it has latched.)
    for &kind in LawKind::ALL.iter() {
        let script = [
            Step::Send(Command::MoveTo {
                to_rad: (45.0 * DEG) as f32,
                time_s: Some(0.5),
            }),
            Step::Wait(0.1),
            Step::Sensor(SensorFault::EncoderStuck),
            Step::Wait(0.3),
            Step::Send(Command::Status),
        ];
        let r = common::run_shipped(kind, &script).unwrap_or_else(|e| panic!("{kind}: {e}"));
        let stuck_at = r.exchanges[0].t + 0.1;
        let tripped = r
            .ticks
            .iter()
            .find(|k| k.mode == Mode::Fault)
            .unwrap_or_else(|| panic!("{kind}: a stuck encoder must latch"));
        let after = tripped.t - stuck_at;
        println!("{kind:>10}: latched {:.3} s after the encoder stuck", after);
        assert!(after <= 0.1, "{kind}: {after} s");
        match r.exchanges[1].reply.outcome {
            Outcome::Status(s) => {
                assert!(
                    FaultFlags(s.faults).contains(FaultFlags::ENCODER_STUCK),
                    "{kind}: {}",
                    FaultFlags(s.faults)
                )
            }
            other => panic!("{other:?}"),
        }
    }
}
