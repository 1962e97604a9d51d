//! Speed of the host simulation and of one controller tick (criterion; run with
//! `cargo bench -p host-tests`). Figures are recorded in docs/testing.md.

// criterion_group! generates an undocumented public function.
#![allow(missing_docs)]

use criterion::{black_box, criterion_group, criterion_main, Criterion};
use host_tests::sim::{paper_slew, settings_for, simulate, SimOptions, HAND_PICKED_SMC};
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
}

fn controller_step(c: &mut Criterion) {
    let m = model::<3>();
    let settings = settings_for(&m, &SimOptions::default().sensors);
    let law = ControlLaw::try_build(Law::Smc(HAND_PICKED_SMC), &m).unwrap();
    let mut ctl = Controller::try_build(settings, law, paper_slew().unwrap()).unwrap();
    ctl.step(&RawMeasurement::default());
    ctl.start_move().unwrap();
    // Hold the hub still mid-move: the law runs in full every tick and nothing faults.
    let raw = RawMeasurement {
        encoder_raw: 0,
        strain_root_code: 100,
        amp_fault: false,
        driver_fault: false,
    };
    c.bench_function("controller step (paper SMC)", |b| {
        b.iter(|| black_box(ctl.step(black_box(&raw))))
    });
}

criterion_group!(benches, closed_loop, controller_step);
criterion_main!(benches);
