//! The command protocol against the simulated beam: a session of moves, waypoints, a payload
//! change, a stop and a fault, carried out by model-core's command handler.

mod common;

use beam_sim::commanded::{run_commands, session_script, CommandedRun, Step};
use beam_sim::sensors::SensorConfig;
use beam_wire::command::{Command, Outcome, Refusal};
use model_core::{BeamParams, LawKind, Mode};

const DEG: f32 = core::f32::consts::PI / 180.0;

fn move_to(deg: f32) -> Step {
    Step::Send(Command::MoveTo {
        to_rad: deg * DEG,
        time_s: None,
    })
}

fn done() -> Step {
    Step::UntilDone {
        settle_s: 0.4,
        max_s: 5.0,
    }
}

fn session(kind: LawKind) -> CommandedRun {
    let drive = BeamParams::aluminium();
    run_commands::<3>(
        drive,
        common::shipped(),
        0.0,
        kind,
        0.0,
        &session_script(),
        SensorConfig::default(),
    )
    .unwrap()
}

#[test]
fn a_session_of_commands_moves_the_beam_and_leaves_it_at_rest_after_each_move() {
    let run = session(LawKind::PdFf);
    let outcomes: Vec<Outcome> = run.exchanges.iter().map(|e| e.reply.outcome).collect();
    // Each reply answers its request.
    for e in &run.exchanges {
        assert_eq!(e.reply.seq, e.request.seq);
    }
    let moving = |o: &Outcome| matches!(o, Outcome::Moving { .. });
    assert!(moving(&outcomes[0]), "{:?}", outcomes[0]);
    // Status during the first move: slewing, at the scheduled payload, the law in use.
    match outcomes[1] {
        Outcome::Status(s) => {
            assert_eq!(s.mode, Mode::Slewing as u8);
            assert_eq!(s.law, Some(LawKind::PdFf));
            assert_eq!(s.payload_kg, 0.0);
        }
        other => panic!("{other:?}"),
    }
    // After it: holding, at 45 deg within 0.5 deg.
    match outcomes[2] {
        Outcome::Status(s) => {
            assert_eq!(s.mode, Mode::Holding as u8);
            assert!(
                (s.theta_rad / DEG - 45.0).abs() < 0.5,
                "{}",
                s.theta_rad / DEG
            );
        }
        other => panic!("{other:?}"),
    }
    assert!(moving(&outcomes[3]));
    assert_eq!(outcomes[4], Outcome::Done); // payload
                                            // Each completed move ends at its target with the beam at rest: the hub within 0.5 deg
                                            // 0.25 s after the planned end, and the residual vibration (RMS root strain over
                                            // 0.05-0.25 s after it) under a tenth of the move's own peak strain (the shaper has
                                            // cancelled most of what the move excited; unshaped, the residual is of the order of
                                            // the peak).
    let ends = run.move_ends();
    let starts: Vec<f64> = run
        .exchanges
        .iter()
        .filter(|e| moving(&e.reply.outcome))
        .map(|e| e.t)
        .collect();
    let targets = [45.0, -30.0, -90.0, 90.0];
    for ((end, start), target) in ends.iter().zip(&starts).zip(targets) {
        let theta = run.theta_at(end + 0.25).unwrap() as f32 / DEG;
        assert!((theta - target).abs() < 0.5, "target {target}: {theta} deg");
        let rms = run.rms_strain_ue(end + 0.05, end + 0.25).unwrap();
        let peak = run
            .ticks
            .iter()
            .filter(|k| k.t >= *start && k.t <= *end)
            .map(|k| (k.root_strain * 1e6).abs())
            .fold(0.0, f64::max);
        assert!(rms < 0.1 * peak, "target {target}: {rms} ue of {peak}");
    }
    // The stop: accepted mid-move, the beam comes to rest short of -90 deg.
    let stop = run
        .exchanges
        .iter()
        .position(|e| e.request.command == Command::Stop)
        .unwrap();
    assert!(moving(&outcomes[stop]), "{:?}", outcomes[stop]);
    match outcomes[stop + 1] {
        Outcome::Status(s) => {
            assert_eq!(s.mode, Mode::Holding as u8);
            let deg = s.theta_rad / DEG;
            assert!(deg > -85.0 && deg < 90.0, "{deg}");
            assert!(
                s.omega_rad_s.abs() < 0.05,
                "{s:?} {:?}",
                &run.exchanges[stop]
            );
        }
        other => panic!("{other:?}"),
    }
    // ... and quiet: the stop lasts two periods of the shaped mode, so it leaves less than a
    // tenth of the peak strain the interrupted move had reached.
    let (begun, stop_end) = (run.exchanges[stop - 1].t, ends[4]);
    let rms = run.rms_strain_ue(stop_end + 0.05, stop_end + 0.25).unwrap();
    let peak = run
        .ticks
        .iter()
        .filter(|k| k.t >= begun && k.t <= stop_end)
        .map(|k| (k.root_strain * 1e6).abs())
        .fold(0.0, f64::max);
    assert!(rms < 0.1 * peak, "after the stop: {rms} ue of {peak}");
    // The fault: latched (torque off), cleared, the next move runs. No command of the
    // session is refused, so `beam drive --session` exits 0.
    match outcomes[stop + 2] {
        Outcome::Status(s) => {
            assert_eq!(s.mode, Mode::Fault as u8);
            assert_eq!(s.faults, model_core::FaultFlags::AMP_FAULT.0);
        }
        other => panic!("{other:?}"),
    }
    assert!(!outcomes.iter().any(|o| matches!(o, Outcome::Refused(_))));
    assert_eq!(outcomes[stop + 3], Outcome::Done);
    assert!(moving(&outcomes[stop + 4]));
    match outcomes[stop + 5] {
        Outcome::Status(s) => {
            assert_eq!(s.mode, Mode::Holding as u8);
            assert_eq!(s.faults, 0);
            assert!((s.theta_rad / DEG).abs() < 0.5);
            assert_eq!(s.payload_kg, 0.025);
        }
        other => panic!("{other:?}"),
    }
    // The torque never left the drive's limit.
    assert!(run.ticks.iter().all(|k| k.torque_nm.abs() <= 10.0));
}

#[test]
fn every_refusal_leaves_the_drive_as_it_was() {
    let drive = BeamParams::aluminium();
    let script = [
        // At rest: nothing to stop; a move too fast; out of range; a bad payload; bad times.
        Step::Send(Command::Stop),
        Step::Send(Command::MoveTo {
            to_rad: 90.0 * DEG,
            time_s: Some(0.05),
        }),
        Step::Send(Command::MoveTo {
            to_rad: 270.0 * DEG,
            time_s: None,
        }),
        Step::Send(Command::SetPayload { kg: f32::NAN }),
        Step::Send(Command::SetPayload { kg: -0.1 }),
        Step::Send(Command::MoveThrough {
            waypoints: heapless::Vec::new(),
            time_s: None,
        }),
        Step::Send(Command::MoveTo {
            to_rad: f32::INFINITY,
            time_s: None,
        }),
        Step::Wait(0.05),
        Step::Send(Command::Status),
        // Mid-move: another move and a payload change are refused (no queue).
        move_to(30.0),
        Step::Wait(0.05),
        move_to(-30.0),
        Step::Send(Command::SetPayload { kg: 0.01 }),
        done(),
        Step::Send(Command::Status),
    ];
    let run = run_commands::<3>(
        drive,
        common::shipped(),
        0.0,
        LawKind::PdFf,
        0.0,
        &script,
        SensorConfig::default(),
    )
    .unwrap();
    let o: Vec<Outcome> = run.exchanges.iter().map(|e| e.reply.outcome).collect();
    assert_eq!(o[0], Outcome::Refused(Refusal::NotMoving));
    match o[1] {
        // The closed form: 10/sqrt(3) * pi/2 / T^2 * Mtt = 6 N m at T = 0.2 s or so.
        Outcome::Refused(Refusal::TooFast { needs_s }) => {
            assert!(needs_s > 0.05 && needs_s < 0.3, "{needs_s}")
        }
        other => panic!("{other:?}"),
    }
    assert!(matches!(o[2], Outcome::Refused(Refusal::OutOfRange { .. })));
    assert_eq!(o[3], Outcome::Refused(Refusal::BadArgument));
    assert_eq!(o[4], Outcome::Refused(Refusal::BadArgument));
    assert_eq!(o[5], Outcome::Refused(Refusal::BadArgument));
    assert_eq!(o[6], Outcome::Refused(Refusal::BadArgument));
    // None of it moved the hub or changed the payload.
    match o[7] {
        Outcome::Status(s) => {
            assert_eq!(s.mode, Mode::Idle as u8);
            assert_eq!(s.payload_kg, 0.0);
            assert!(s.theta_rad.abs() < 0.01);
        }
        other => panic!("{other:?}"),
    }
    assert!(matches!(o[8], Outcome::Moving { .. }));
    assert_eq!(o[9], Outcome::Refused(Refusal::Busy));
    assert_eq!(o[10], Outcome::Refused(Refusal::Busy));
    match o[11] {
        Outcome::Status(s) => {
            assert!((s.theta_rad / DEG - 30.0).abs() < 0.5);
            assert_eq!(s.payload_kg, 0.0);
        }
        other => panic!("{other:?}"),
    }
}

/// The drive's run of `script` from rest at `home_deg`, with `kind`.
fn run(kind: LawKind, home_deg: f32, script: &[Step]) -> CommandedRun {
    run_commands::<3>(
        BeamParams::aluminium(),
        common::shipped(),
        0.0,
        kind,
        home_deg * DEG,
        script,
        SensorConfig::default(),
    )
    .unwrap()
}

fn outcomes(run: &CommandedRun) -> Vec<Outcome> {
    run.exchanges.iter().map(|e| e.reply.outcome).collect()
}

fn status(o: &Outcome) -> beam_wire::command::Status {
    match o {
        Outcome::Status(s) => *s,
        other => panic!("not a status: {other:?}"),
    }
}

#[test]
fn a_move_is_running_from_its_answer_on() {
    // Stop on the same tick as the move: the move is cut at its start, the hub stays put.
    let r = run(
        LawKind::PdFf,
        0.0,
        &[move_to(90.0), Step::Send(Command::Stop), done()],
    );
    let o = outcomes(&r);
    assert!(matches!(o[1], Outcome::Moving { .. }), "{o:?}");
    let furthest = r.ticks.iter().map(|k| k.theta.abs()).fold(0.0, f64::max);
    assert!(furthest.to_degrees() < 0.5, "{} deg", furthest.to_degrees());
    // A second move, or a payload, on the same tick: busy, and the first move runs whole.
    let r = run(
        LawKind::PdFf,
        0.0,
        &[
            move_to(90.0),
            move_to(-90.0),
            Step::Send(Command::SetPayload { kg: 0.05 }),
            done(),
            Step::Send(Command::Status),
        ],
    );
    let o = outcomes(&r);
    assert_eq!(o[1], Outcome::Refused(Refusal::Busy));
    assert_eq!(o[2], Outcome::Refused(Refusal::Busy));
    let s = status(&o[3]);
    assert!(
        (s.theta_rad / DEG - 90.0).abs() < 0.5,
        "{}",
        s.theta_rad / DEG
    );
    assert_eq!(s.payload_kg, 0.0);
}

#[test]
fn clearing_a_fault_keeps_the_angle_the_drive_reports() {
    // From rest at 45 deg: the status right after `clear` reports 45 deg, not the zero, and
    // a move planned then starts where the hub is (no start-mismatch fault).
    let r = run(
        LawKind::PdFf,
        45.0,
        &[
            Step::Send(Command::ClearFault),
            Step::Send(Command::Status),
            move_to(10.0),
            done(),
            Step::Send(Command::Status),
        ],
    );
    let o = outcomes(&r);
    assert!((status(&o[1]).theta_rad / DEG - 45.0).abs() < 0.01);
    assert!(matches!(o[2], Outcome::Moving { .. }));
    let s = status(&o[3]);
    assert_eq!(s.faults, 0);
    assert!((s.theta_rad / DEG - 10.0).abs() < 0.5);
}

#[test]
fn a_hub_that_coasted_out_of_range_is_braked_and_brought_back_by_every_law() {
    // The torque off mid-move: the hub coasts turns past the range. A move is refused while
    // it turns; `stop` brakes it (the drive's brake, whatever the law); then a move back
    // into the range is accepted and ends there.
    for &kind in LawKind::ALL.iter() {
        let r = run(
            kind,
            0.0,
            &[
                move_to(170.0),
                Step::Wait(0.2),
                Step::Send(Command::Disable),
                Step::Wait(1.0),
                Step::Send(Command::Status),
                move_to(0.0),
                Step::Send(Command::Stop),
                Step::UntilDone {
                    settle_s: 1.0,
                    max_s: 5.0,
                },
                Step::Send(Command::Status),
                move_to(0.0),
                // (The paper's SMC lags a move of many turns and creeps back to its end in
                // about a second.)
                Step::UntilDone {
                    settle_s: 1.5,
                    max_s: 5.0,
                },
                Step::Send(Command::Status),
            ],
        );
        let o = outcomes(&r);
        let coasting = status(&o[2]);
        assert!(
            coasting.theta_rad > core::f32::consts::PI,
            "{kind}: {coasting:?}"
        );
        assert!(coasting.omega_rad_s.abs() > 1.0, "{kind}: {coasting:?}");
        assert_eq!(o[3], Outcome::Refused(Refusal::HubMoving), "{kind}");
        assert!(matches!(o[4], Outcome::Moving { .. }), "{kind}: {:?}", o[4]);
        let braked = status(&o[5]);
        assert_eq!(braked.faults, 0, "{kind}: {braked:?}");
        assert!(braked.theta_rad > core::f32::consts::PI, "{kind}");
        assert!(matches!(o[6], Outcome::Moving { .. }), "{kind}: {:?}", o[6]);
        let back = status(&o[7]);
        assert_eq!(back.faults, 0, "{kind}");
        assert!((back.theta_rad / DEG).abs() < 0.5, "{kind}: {back:?}");
        assert!(r.ticks.iter().all(|k| k.torque_nm.abs() <= 10.0));
    }
}

#[test]
fn the_stated_range_is_the_real_one_and_moves_have_a_longest_time() {
    let r = run(
        LawKind::PdFf,
        0.0,
        &[
            move_to(180.0),
            done(),
            move_to(-180.0),
            done(),
            Step::Send(Command::Status),
            move_to(180.1),
            Step::Send(Command::MoveTo {
                to_rad: 45.0 * DEG,
                time_s: Some(1e30),
            }),
            Step::Send(Command::MoveTo {
                to_rad: 45.0 * DEG,
                time_s: Some(model_core::planner::MAX_MOVE_S + 1.0),
            }),
            Step::Send(Command::SetPayload {
                kg: common::shipped().plant.max_payload_kg() + 0.01,
            }),
            Step::Send(Command::Status),
        ],
    );
    let o = outcomes(&r);
    assert!(matches!(o[0], Outcome::Moving { .. }), "{:?}", o[0]);
    assert!(matches!(o[1], Outcome::Moving { .. }), "{:?}", o[1]);
    assert!((status(&o[2]).theta_rad / DEG + 180.0).abs() < 0.5);
    assert!(matches!(o[3], Outcome::Refused(Refusal::OutOfRange { .. })));
    let too_long = Outcome::Refused(Refusal::TooLong {
        max_s: model_core::planner::MAX_MOVE_S,
    });
    assert_eq!(o[4], too_long);
    assert_eq!(o[5], too_long);
    assert_eq!(o[6], Outcome::Refused(Refusal::BadArgument));
    // None of the refusals moved anything.
    assert_eq!(status(&o[7]).mode, Mode::Holding as u8);
}

#[test]
fn a_move_commanded_while_the_hub_coasts_is_refused() {
    let r = run(
        LawKind::PdFf,
        0.0,
        &[
            move_to(90.0),
            Step::Wait(0.2),
            Step::Send(Command::Disable),
            move_to(0.0),
            Step::Wait(0.1),
        ],
    );
    let o = outcomes(&r);
    assert_eq!(o[2], Outcome::Refused(Refusal::HubMoving));
    // The torque stayed off after the disable.
    let off = r.exchanges[1].t;
    assert!(r
        .ticks
        .iter()
        .filter(|k| k.t > off)
        .all(|k| k.torque_nm == 0.0));
}
