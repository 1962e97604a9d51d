//! Closed-loop behaviour of the model-core controller on the simulated plant.
//!
//! The facts checked come from the physics, not from earlier output: a slew that settles
//! must end at its target and at rest; the model must break down for Table 1's printed EI
//! (docs/design.md, section 2: the model leaves its range within about 0.2 s); the
//! sliding-mode controller must leave less residual vibration than the PD baseline.

use host_tests::metrics::metrics;
use host_tests::sim::{simulate, Integrator, SimOptions, HAND_PICKED_SMC, HAND_PICKED_SMC_STRAIN};
use model_core::{Beam, BeamParams, Law, ModalModel, PdGains};

fn model<const N: usize>(params: BeamParams) -> ModalModel<N> {
    ModalModel::try_build(&Beam::try_build(params).unwrap()).unwrap()
}

#[test]
fn smc_and_pd_settle_the_aluminium_slew_and_smc_leaves_less_vibration() {
    let m = model::<3>(BeamParams::aluminium());
    let opts = SimOptions::default();
    let pd = simulate(&m, Law::Pd(PdGains::BASELINE), &opts).unwrap();
    let smc = simulate(&m, Law::Smc(HAND_PICKED_SMC), &opts).unwrap();
    for (name, run) in [("pd", &pd), ("smc", &smc)] {
        assert!(run.breakdown.is_none(), "{name}: {:?}", run.breakdown);
        assert!(run.faults.is_empty(), "{name}: {}", run.faults);
        let m = metrics(run);
        // Settled: at the target within half a degree, and at rest, at 2 s.
        assert!(m.err_deg_t2_0.unwrap() < 0.5, "{name}: {:?}", m);
        let last = run.samples.last().unwrap();
        assert!(
            last.omega.abs() < 0.02,
            "{name}: still moving at {} rad/s",
            last.omega
        );
        assert!(m.settle_s.is_some(), "{name}: tip never settled");
        assert!(m.peak_torque_nm.unwrap() <= 10.0);
    }
    let (mp, ms) = (metrics(&pd), metrics(&smc));
    let (rp, rs) = (
        mp.rms_root_strain_ue_0_4_0_6.unwrap(),
        ms.rms_root_strain_ue_0_4_0_6.unwrap(),
    );
    assert!(
        rs < rp,
        "SMC residual RMS {rs} ue is not below PD's {rp} ue"
    );
    // Residual vibration once the move is well over: the largest root strain after 1 s.
    let tail = |run: &host_tests::sim::SimResult| {
        run.samples
            .iter()
            .filter(|s| s.t >= 1.0)
            .map(|s| s.root_strain.abs())
            .fold(0.0, f64::max)
    };
    assert!(
        tail(&smc) < tail(&pd),
        "after 1 s: smc {} vs pd {}",
        tail(&smc),
        tail(&pd)
    );
    assert!(ms.settle_s.unwrap() < mp.settle_s.unwrap());
}

#[test]
fn strain_augmented_smc_settles_too() {
    let m = model::<3>(BeamParams::aluminium());
    let run = simulate(
        &m,
        Law::SmcStrain(HAND_PICKED_SMC_STRAIN),
        &SimOptions::default(),
    )
    .unwrap();
    assert!(run.breakdown.is_none());
    let r = metrics(&run);
    assert!(
        r.err_deg_t2_0.unwrap() < 0.5 && r.settle_s.is_some(),
        "{r:?}"
    );
}

#[test]
fn every_mode_count_runs_without_breakdown() {
    fn check<const N: usize>() {
        let run = simulate(
            &model::<N>(BeamParams::aluminium()),
            Law::Smc(HAND_PICKED_SMC),
            &SimOptions::default(),
        )
        .unwrap();
        assert!(run.breakdown.is_none(), "{N} modes");
        assert!(metrics(&run).err_deg_t2_0.unwrap() < 0.5, "{N} modes");
    }
    check::<1>();
    check::<2>();
    check::<3>();
    check::<4>();
}

#[test]
fn table1_as_printed_breaks_the_model_and_reports_no_metrics() {
    let m = model::<3>(BeamParams::table1());
    for law in [Law::Smc(HAND_PICKED_SMC), Law::Pd(PdGains::BASELINE)] {
        let run = simulate(&m, law, &SimOptions::default()).unwrap();
        let (t, _why) = run
            .breakdown
            .clone()
            .expect("table1's soft beam must leave the model's range");
        assert!(
            t < 0.35,
            "{}: breakdown at {t} s, expected during the move",
            law.name()
        );
        let r = metrics(&run);
        assert_eq!(r.breakdown_at_s, Some(t));
        assert!(
            r.cost_j.is_none() && r.rms_root_strain_ue_0_4_0_6.is_none() && r.settle_s.is_none()
        );
    }
}

#[test]
fn fast_and_reference_integrators_give_the_same_closed_loop_metrics() {
    // The runner's RK4 against DOP853 at tight tolerances on the whole closed loop (same
    // sensor noise seed). The controller sees quantised counts, so a last-digit difference may
    // flip a count now and then: compare the physical outcome, not bits.
    let m = model::<3>(BeamParams::aluminium());
    let fast = simulate(
        &m,
        Law::Smc(HAND_PICKED_SMC),
        &SimOptions {
            duration_s: 1.0,
            ..Default::default()
        },
    )
    .unwrap();
    let reference = simulate(
        &m,
        Law::Smc(HAND_PICKED_SMC),
        &SimOptions {
            duration_s: 1.0,
            integrator: Integrator::Dop853 {
                rtol: 1e-10,
                atol: 1e-12,
            },
            ..Default::default()
        },
    )
    .unwrap();
    let worst_theta = fast
        .samples
        .iter()
        .zip(&reference.samples)
        .map(|(a, b)| (a.theta - b.theta).abs())
        .fold(0.0, f64::max);
    let worst_strain = fast
        .samples
        .iter()
        .zip(&reference.samples)
        .map(|(a, b)| (a.root_strain - b.root_strain).abs())
        .fold(0.0, f64::max);
    // One encoder count is 3.8e-4 rad; the strain peaks near 1300 microstrain.
    assert!(worst_theta < 4e-4, "hub angles differ by {worst_theta} rad");
    assert!(worst_strain < 2e-6, "root strains differ by {worst_strain}");
}
