//! The drive's command path on arbitrary bytes: frames that do not decode as a `Request` are
//! rejected by name; every request that does decode is carried out by model-core's handler
//! without a panic, and a refused one changes neither the controller nor the handler.
#![no_main]

use beam_wire::command::{Outcome, Request};
use beam_wire::{decode, encode, FrameReader, MAX_FRAME};
use libfuzzer_sys::fuzz_target;
use model_core::commands::{CommandedController, Commander};
use model_core::{Controller, ControllerSettings, LawKind, RawMeasurement, Spline};
use std::sync::OnceLock;

fn drive() -> &'static (Commander, CommandedController) {
    static DRIVE: OnceLock<(Commander, CommandedController)> = OnceLock::new();
    DRIVE.get_or_init(|| {
        let (commander, law) = Commander::try_new(
            &model_core::gains::PLANT,
            model_core::gains::GAIN_TABLE,
            LawKind::PdFf,
            0.0,
        )
        .expect("the shipped configuration builds");
        let rest = Spline::try_build(&[(0.0, 0.0), (1.0, 0.0)]).expect("a rest move");
        let mut ctl = Controller::try_build(ControllerSettings::default(), law, rest)
            .expect("default settings build");
        // A few idle ticks, so the handler sees a measured angle.
        let raw = RawMeasurement::default();
        for _ in 0..5 {
            ctl.step(&raw);
        }
        (commander, ctl)
    })
}

fuzz_target!(|data: &[u8]| {
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
        let (mut commander, mut ctl) = drive().clone();
        let before = (commander.clone(), ctl.clone());
        let reply = commander.handle(&mut ctl, &request);
        assert_eq!(reply.seq, request.seq);
        if let Outcome::Refused(_) = reply.outcome {
            assert!(before == (commander, ctl), "a refusal changed the drive");
        }
    }
});
