//! The drive's command path on arbitrary bytes: frames that do not decode as a `Request` are
//! rejected by name; every request that does decode is carried out by model-core's handler
//! without a panic, and a refused one changes neither the controller nor the handler. The
//! first byte picks the drive's state (idle, a move armed, slewing, holding, faulted, the hub
//! coasting).
#![no_main]

use beam_wire::command::{Command, Outcome, Request};
use beam_wire::{decode, encode, FrameReader, MAX_FRAME};
use libfuzzer_sys::fuzz_target;
use model_core::commands::{CommandedController, Commander};
use model_core::{Controller, LawKind, Mode, RawMeasurement, Spline};
use std::sync::OnceLock;

/// `raw` with a live bridge's code: a few hundred codes of noise that change every reading
/// (a converter that reads one code on end has stopped, and the controller latches `gauge`).
fn live(raw: RawMeasurement) -> RawMeasurement {
    use std::sync::atomic::{AtomicU32, Ordering};
    static READS: AtomicU32 = AtomicU32::new(0);
    let n = READS.fetch_add(1, Ordering::Relaxed).wrapping_add(1);
    RawMeasurement {
        strain_root_code: raw.strain_root_code + (n.wrapping_mul(2_654_435_761) >> 24) as i32 - 128,
        ..raw
    }
}

/// The drive in each state a command can meet, built once: idle, a move answered but not
/// yet started, slewing, holding, faulted, and idle with the hub coasting (the torque off).
/// The input's first byte picks one.
fn drives() -> &'static [(Commander<'static>, CommandedController)] {
    static DRIVES: OnceLock<Vec<(Commander<'static>, CommandedController)>> = OnceLock::new();
    DRIVES.get_or_init(|| {
        // The shipped table, loaded as the host tools load it.
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../gains.toml");
        let table = gain_table::open(&path)
            .expect("the shipped table loads")
            .leak();
        let (commander, law) = Commander::try_new(table, LawKind::PdFf, 0.0)
            .expect("the shipped configuration builds");
        let rest = Spline::try_build(&[(0.0, 0.0), (1.0, 0.0)]).expect("a rest move");
        let settings = table.settings(-core::f32::consts::FRAC_PI_2);
        let mut ctl = Controller::try_build(settings, law, rest).expect("the settings build");
        // A few idle ticks, so the handler sees a measured angle.
        let raw = RawMeasurement::default();
        let ticks = |ctl: &mut CommandedController, n: usize, raw: &RawMeasurement| {
            for _ in 0..n {
                ctl.step(&live(*raw));
            }
        };
        ticks(&mut ctl, 5, &raw);
        let idle = (commander.clone(), ctl.clone());
        let go = |to_rad: f32| {
            let (mut c, mut ctl) = idle.clone();
            let request = Request {
                seq: 1,
                command: Command::MoveTo {
                    to_rad,
                    time_s: None,
                },
            };
            let reply = c.handle(&mut ctl, &request);
            assert!(matches!(reply.outcome, Outcome::Moving { .. }), "{reply:?}");
            (c, ctl)
        };
        let armed = go(0.5);
        let mut slewing = go(0.5);
        ticks(&mut slewing.1, 10, &raw);
        // Holding: the hub follows the move to its end (the encoder reads the reference).
        let mut holding = go(0.5);
        let rad_per_count = settings.encoder.rad_per_count() as f32;
        for k in 0..4000u32 {
            let pos = holding.1.spline().eval(k as f32 * 1e-3).pos - settings.theta_home_rad;
            let on = RawMeasurement {
                encoder_raw: ((pos / rad_per_count).round() as i32 as u32)
                    & settings.encoder.mask(),
                ..raw
            };
            holding.1.step(&live(on));
        }
        let mut faulted = idle.clone();
        let fault = RawMeasurement {
            amp_fault: true,
            ..raw
        };
        ticks(&mut faulted.1, 1, &fault);
        let mut coasting = idle.clone();
        for k in 1..=50u32 {
            let turning = RawMeasurement {
                encoder_raw: 5 * k,
                ..raw
            };
            ticks(&mut coasting.1, 1, &turning);
        }
        let modes = [&idle, &armed, &slewing, &holding, &faulted, &coasting].map(|d| d.1.mode());
        let expected = [
            Mode::Idle,
            Mode::Slewing,
            Mode::Slewing,
            Mode::Holding,
            Mode::Fault,
            Mode::Idle,
        ];
        if modes != expected {
            panic!("states {modes:?}; holding's faults: {}", holding.1.faults());
        }
        vec![idle, armed, slewing, holding, faulted, coasting]
    })
}

fuzz_target!(|data: &[u8]| {
    // The first byte picks the state and is read as the frame's too, so the seed frames
    // stay frames.
    let Some(&pick) = data.first() else {
        return;
    };
    let drives = drives();
    let start = &drives[pick as usize % drives.len()];
    let mut reader = FrameReader::new();
    for &b in data {
        let Some(Ok(frame)) = reader.push(b) else {
            continue;
        };
        let mut copy = frame.to_vec();
        let Ok(request) = decode::<Request>(&mut copy) else {
            continue;
        };
        // It re-encodes to a frame that decodes to the same request.
        let mut buf = [0u8; MAX_FRAME + 1];
        let mut again = encode(&request, &mut buf).expect("re-encodes").to_vec();
        again.pop();
        assert_eq!(decode::<Request>(&mut again), Ok(request.clone()));
        let (mut commander, mut ctl) = start.clone();
        let before = (commander.clone(), ctl.clone());
        let reply = commander.handle(&mut ctl, &request);
        assert_eq!(reply.seq, request.seq);
        if let Outcome::Refused(_) = reply.outcome {
            assert!(before == (commander, ctl), "a refusal changed the drive");
        }
    }
});
