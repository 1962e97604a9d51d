//! Calibration on a synthetic experiment: a PD-driven slew of a plant whose parameters are
//! known and differ from the starting guess by 12-15 %, with 3 modes, Coulomb friction,
//! encoder quantisation and strain noise. Only the logged CSV goes into the calibration; the
//! identified model must recover the rigid-body inertia within 5 % and the first hub-free
//! frequency within 2 %.

use beam_tools::calibrate::{calibrate, read_log};
use beam_tools::files::write_trace_csv;
use host_tests::sim::{simulate, SimOptions};
use model_core::{Beam, BeamParams, Law, ModalModel, PdGains};

fn model(p: BeamParams) -> ModalModel<3> {
    ModalModel::try_build(&Beam::try_build(p).unwrap()).unwrap()
}

#[test]
fn calibration_recovers_the_plant_from_its_log() {
    let guess = BeamParams {
        coulomb_nm: 0.02,
        ..BeamParams::aluminium()
    };
    let truth = BeamParams {
        ei_nm2: guess.ei_nm2 * 1.15,
        density_kg_m3: guess.density_kg_m3 * 0.87,
        jm_kgm2: guess.jm_kgm2 * 1.12,
        viscous_nms: guess.viscous_nms * 0.85,
        coulomb_nm: guess.coulomb_nm * 1.15,
        ..guess
    };
    let run = simulate(
        &model(truth),
        Law::Pd(PdGains::BASELINE),
        &SimOptions {
            duration_s: 0.8,
            ..Default::default()
        },
    )
    .unwrap();
    assert!(run.breakdown.is_none());
    let mut csv = Vec::new();
    write_trace_csv(&run, &mut csv).unwrap();
    let log = read_log(std::str::from_utf8(&csv).unwrap(), "experiment.csv").unwrap();
    // The log is what a drive sees: the angle is quantised to encoder counts.
    let count = 2.0 * std::f64::consts::PI / 16384.0;
    assert!(log
        .theta
        .iter()
        .all(|th| ((th + std::f64::consts::FRAC_PI_2) / count
            - ((th + std::f64::consts::FRAC_PI_2) / count).round())
        .abs()
            < 1e-3));

    let (found, steps) =
        calibrate::<3>(&log, &guess, beam_tools::calibrate::DEFAULT_EVALS).unwrap();
    for s in &steps {
        eprintln!(
            "{:20} {:?} rms theta {:.2e} rad, strain {:.2} ue",
            s.name, s.fitted, s.rms_theta_err_rad, s.rms_strain_err_ue
        );
    }
    let (t, f) = (model(truth), model(found));
    let rel = |a: f64, b: f64| (a - b).abs() / b.abs();
    assert!(
        rel(found.jm_kgm2, truth.jm_kgm2) < 0.05,
        "Jm {} vs {}",
        found.jm_kgm2,
        truth.jm_kgm2
    );
    assert!(rel(f.mtt, t.mtt) < 0.05, "Mtt {} vs {}", f.mtt, t.mtt);
    assert!(rel(f.jeff, t.jeff) < 0.05, "Jeff {} vs {}", f.jeff, t.jeff);
    assert!(
        rel(f.pinned_hz[0], t.pinned_hz[0]) < 0.02,
        "pinned {} vs {} Hz",
        f.pinned_hz[0],
        t.pinned_hz[0]
    );
    // The guess itself was outside those bands, so the calibration did the work.
    let g = model(guess);
    assert!(rel(guess.jm_kgm2, truth.jm_kgm2) > 0.05 && rel(g.pinned_hz[0], t.pinned_hz[0]) > 0.02);
    // The fit explains the log down to about the encoder's resolution.
    assert!(steps[2].rms_theta_err_rad < 5.0 * count, "{:?}", steps[2]);
}
