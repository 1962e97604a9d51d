//! Speed of the host simulation and of one controller tick (criterion; run with
//! `cargo bench -p beam-sim`). Figures are recorded in docs/testing.md.

// criterion_group! generates an undocumented public function.
#![allow(missing_docs)]

use beam_sim::sim::{
    paper_slew, settings_for, simulate, SimOptions, HAND_PICKED_LQG, HAND_PICKED_SMC,
};
use criterion::{black_box, criterion_group, criterion_main, Criterion};
use model_core::{Beam, BeamParams, ControlLaw, Controller, Law, ModalModel, RawMeasurement};

fn model<const N: usize>() -> ModalModel<N> {
    ModalModel::try_build(&Beam::try_build(BeamParams::aluminium()).unwrap()).unwrap()
}

fn closed_loop(c: &mut Criterion) {
    let opts = SimOptions {
        duration_s: 2.0,
        ..SimOptions::default()
    };
    let m1 = model::<1>();
    let m3 = model::<3>();
    c.bench_function("closed loop 2 s, 1 mode, SMC", |b| {
        b.iter(|| simulate(black_box(&m1), Law::Smc(HAND_PICKED_SMC), &opts).unwrap())
    });
    c.bench_function("closed loop 2 s, 3 modes, SMC", |b| {
        b.iter(|| simulate(black_box(&m3), Law::Smc(HAND_PICKED_SMC), &opts).unwrap())
    });
    // The LQG law's design (two Riccati equations) is part of each run, as in a sweep.
    c.bench_function("closed loop 2 s, 3 modes, LQG", |b| {
        b.iter(|| simulate(black_box(&m3), Law::Lqg(HAND_PICKED_LQG), &opts).unwrap())
    });
}

fn controller_step(c: &mut Criterion) {
    step_of(
        c,
        "controller step (paper SMC)",
        Law::Smc(HAND_PICKED_SMC),
        false,
    );
    step_of(c, "controller step (LQG)", Law::Lqg(HAND_PICKED_LQG), true);
}

/// `observer`: the law runs an observer, which must be what is timed (checked after).
fn step_of(c: &mut Criterion, name: &str, law: Law, observer: bool) {
    let m = model::<3>();
    let sensors = SimOptions::default().sensors;
    let settings = settings_for(&m, &sensors);
    // Designed on the instruments the loop reads, as the drive's observer laws are.
    let law = ControlLaw::try_build(law, sensors.instruments().on(&m)).unwrap();
    let mut ctl = Controller::try_build(settings, law, paper_slew().unwrap()).unwrap();
    ctl.step(&RawMeasurement::default());
    ctl.start_move().unwrap();
    // The hub walks one encoder count a tick, 200 counts (4.4 deg) forward and back: the law
    // runs in full every tick (slewing, then holding) and nothing faults. A hub held still
    // under torque would latch the stall fault after 20 ticks, and one that crept on would
    // leave the drive's range; the torque-off path is not what is measured here. No fault
    // may latch (checked after the run): a latched gauge fault would time the drive's own
    // law in place of an observer law.
    let mut tick = 0u32;
    c.bench_function(name, |b| {
        b.iter(|| {
            tick = (tick + 1) % 400;
            let raw = RawMeasurement {
                encoder_raw: tick.min(400 - tick),
                // A live bridge: its code moves every conversion (a constant one is a
                // frozen converter, which latches `gauge` after 10 ticks and hands the
                // observer laws over to the drive's own law, so their observer would not
                // be timed).
                strain_root_code: 100 + (tick.wrapping_mul(2_654_435_761) % 1601) as i32,
                amp_fault: false,
                driver_fault: false,
            };
            black_box(ctl.step(black_box(&raw)))
        })
    });
    assert!(ctl.faults().is_empty(), "{name}: {}", ctl.faults());
    // Still the law's own tick, not the drive's own law it hands over to: its observer moves.
    if observer {
        let before = ctl.law_state().lqg;
        ctl.step(&RawMeasurement {
            encoder_raw: 7,
            strain_root_code: 900,
            ..RawMeasurement::default()
        });
        assert_ne!(
            before,
            ctl.law_state().lqg,
            "{name}: the observer did not run"
        );
    }
}

criterion_group!(benches, closed_loop, controller_step);
criterion_main!(benches);
