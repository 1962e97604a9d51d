//! The LQG law's modal observer against the simulated beam's true state.
//!
//! The drive measures the hub angle (encoder) and the root strain (gauge) only. What the
//! observer infers beyond them, through the drive's own mode shapes, is checked against the
//! plant: the mid-span strain and the tip deflection (neither is measured) and the hub rate,
//! over a 180 deg slew at each payload, and on beams whose EI, density and hub inertia are
//! off by 20 % from the model the observer was designed on.

mod common;

use beam_sim::plant::Plant;
use beam_sim::sensors::SensorConfig;
use beam_sim::sim::{
    run_with, settings_for, simulate_knowing, simulate_mismatched, Known, Motion, SimOptions,
    SimResult, TrueState, HAND_PICKED_LQG,
};
use model_core::law::Adaptation;
use model_core::law::LawPlant;
use model_core::lqg::{LqgDesign, LqgError, LqgWeights, DESIGN_MODES, MAX_STATES};
use model_core::{
    Beam, BeamParams, ControlLaw, Controller, ControllerSettings, Law, Limits, ModalModel,
    PlantPoint,
};

fn model(params: BeamParams) -> ModalModel<3> {
    ModalModel::try_build(&Beam::try_build(params).unwrap()).unwrap()
}

/// A 180 deg slew at the planner's shortest time and the time after it (1.5 s in all) under
/// the LQG law, its observer designed on `nominal` and the instruments of `sensors`, on the
/// beam `plant`: the run and the observer's estimate after each tick.
fn observed(
    plant: BeamParams,
    nominal: BeamParams,
    sensors: SensorConfig,
) -> (SimResult, Vec<[f32; MAX_STATES]>) {
    observed_or_fed(plant, nominal, sensors, false, true)
}

/// A plant whose observer design carries no identifier: the observer runs on the model's
/// stiffness throughout, as the LQG law did before it identified the beam.
struct NoIdentifier<P>(P);

impl<P: LawPlant> LawPlant for NoIdentifier<P> {
    fn point(&self) -> PlantPoint {
        self.0.point()
    }

    fn lqg(&self, weights: &LqgWeights, ts_s: f64) -> Option<Result<LqgDesign, LqgError>> {
        let weights = LqgWeights {
            identify: false,
            ..*weights
        };
        self.0.lqg(&weights, ts_s)
    }
}

/// [`observed`], or with `true_state` the law fed the plant's true state in place of its
/// observer's estimate ([`SimOptions::true_state`]), and without `identify` the observer on
/// the model's stiffness throughout ([`NoIdentifier`]).
fn observed_or_fed(
    plant: BeamParams,
    nominal: BeamParams,
    sensors: SensorConfig,
    true_state: bool,
    identify: bool,
) -> (SimResult, Vec<[f32; MAX_STATES]>) {
    let (p, n) = (model(plant), model(nominal));
    // The move the drive makes: 180 deg at the planner's shortest time, with the shipped
    // lqg rows' shaper for the payload the drive was told.
    let shaper = common::shipped().shaper(model_core::LawKind::Lqg, nominal.tip_mass_kg as f32);
    let opts = SimOptions {
        duration_s: 1.5,
        idle_ticks: 0,
        motion: Motion {
            shortest: true,
            shaper,
            ..Motion::default()
        },
        sensors,
        true_state,
        ..SimOptions::default()
    };
    let settings = ControllerSettings {
        theta_home_rad: opts.motion.from_rad,
        ..settings_for(&n, &opts.sensors)
    };
    let on = opts.sensors.instruments().on(&n);
    let lqg = Law::Lqg(HAND_PICKED_LQG);
    let law = match (true_state, identify) {
        (false, true) => ControlLaw::try_build(lqg, on),
        (true, true) => ControlLaw::try_build(lqg, TrueState(on)),
        (false, false) => ControlLaw::try_build(lqg, NoIdentifier(on)),
        (true, false) => ControlLaw::try_build(lqg, TrueState(NoIdentifier(on))),
    }
    .unwrap();
    let spline = opts.motion.plan(&Limits::for_law(&n, &lqg)).unwrap();
    let reference = spline.clone();
    let controller = Controller::try_build(settings, law, spline).unwrap();
    let mut rec = common::Recording::new(controller);
    let run = run_with(Plant::new(p), &mut rec, &reference, &opts).unwrap();
    assert!(
        run.breakdown.is_none() && run.faults.is_empty(),
        "{:?} {:?}",
        run.breakdown,
        run.faults
    );
    (run, rec.states.iter().map(|s| s.estimate).collect())
}

/// Relative RMS errors of the estimated mid-span strain, tip deflection and hub rate over a
/// 180 deg slew and the time after it (1.5 s in all), with the observer designed on `nominal` and the
/// beam `plant`.
fn errors(plant: BeamParams, nominal: BeamParams) -> (f64, f64, f64) {
    let n = model(nominal);
    let (run, estimates) = observed(plant, nominal, SensorConfig::default());
    // Estimate k was made from the readings of sample k's state.
    let rms = |v: &[f64]| (v.iter().map(|x| x * x).sum::<f64>() / v.len() as f64).sqrt();
    // The estimate holds the observed modes, then the hub rate (beam_model::lqg's layout).
    let modes = |x: &[f32; MAX_STATES], coef: &[f64; 3]| -> f64 {
        (0..DESIGN_MODES).map(|i| coef[i] * x[1 + i] as f64).sum()
    };
    let rate = 1 + DESIGN_MODES;
    let (mut mid, mut tip, mut omega) = ((vec![], vec![]), (vec![], vec![]), (vec![], vec![]));
    for (s, x) in run.samples.iter().zip(&estimates) {
        mid.0.push(s.mid_strain);
        mid.1.push(modes(x, &n.mid_strain_coef) - s.mid_strain);
        tip.0.push(s.w_tip);
        tip.1.push(modes(x, &n.tip_coef) - s.w_tip);
        omega.0.push(s.omega);
        omega.1.push(x[rate] as f64 - s.omega);
    }
    let rel = |(truth, err): (Vec<f64>, Vec<f64>)| rms(&err) / rms(&truth);
    (rel(mid), rel(tip), rel(omega))
}

#[test]
fn the_observer_tracks_what_the_drive_does_not_measure() {
    for payload in [0.0, 0.025, 0.05] {
        let beam = BeamParams {
            tip_mass_kg: payload,
            ..BeamParams::aluminium()
        };
        let (mid, tip, omega) = errors(beam, beam);
        eprintln!("{payload} kg: mid strain {mid:.4}, tip {tip:.4}, hub rate {omega:.4}");
        // On its own model the estimate is within a few percent: what is left is the third
        // mode, which the law leaves unobserved (model_core::law::LQG_MODES).
        assert!(mid < 0.05 && tip < 0.05 && omega < 0.03, "{payload} kg");
    }
}

#[test]
fn the_observer_tracks_a_beam_a_fifth_off_its_model() {
    let nominal = BeamParams::aluminium();
    for (ei, rho, jm) in [
        (1.2, 1.0, 1.0),
        (0.8, 1.0, 1.0),
        (1.0, 1.2, 0.8),
        (0.8, 0.8, 1.2),
    ] {
        let plant = BeamParams {
            ei_nm2: nominal.ei_nm2 * ei,
            density_kg_m3: nominal.density_kg_m3 * rho,
            jm_kgm2: nominal.jm_kgm2 * jm,
            ..nominal
        };
        let (mid, tip, omega) = errors(plant, nominal);
        eprintln!("EI x{ei}, rho x{rho}, Jm x{jm}: mid strain {mid:.4}, tip {tip:.4}, hub rate {omega:.4}");
        // On a model a fifth off, the estimate may be off by up to as much, never by its
        // own size (which an observer that lost the beam is).
        assert!(
            mid < 0.2 && tip < 0.2 && omega < 0.2,
            "EI x{ei}, rho x{rho}, Jm x{jm}"
        );
    }
}

/// What the observer's estimate of the root strain loses against the true beam after the
/// move, ue RMS and peak, split by mode: the observed modes' errors and the unobserved third
/// mode's whole share.
struct Loss {
    total_rms: f64,
    total_peak: f64,
    per_mode_rms: [f64; 3],
}

/// [`Loss`] of the observer designed on the aluminium beam, on the beam `plant`: the
/// modal coordinates compared one to one, which holds where the plant differs by EI alone
/// (a uniform beam's mode shapes do not depend on it).
fn loss_on(plant: BeamParams, sensors: SensorConfig, identify: bool) -> Loss {
    let beam = BeamParams::aluminium();
    // The root strain's coefficients do not depend on EI either: one set serves both.
    let n = model(plant);
    let (run, estimates) = observed_or_fed(plant, beam, sensors, false, identify);
    // The true modal coordinates from the three true outputs (each linear in them).
    let rows = [n.root_strain_coef, n.mid_strain_coef, n.tip_coef];
    let mut a = [[0.0f64; 3]; 3];
    for (i, r) in rows.iter().enumerate() {
        a[i] = *r;
    }
    // Cramer's rule: the three outputs see the three modes.
    let det3 = |m: &[[f64; 3]; 3]| {
        m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
            - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
            + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
    };
    let d = det3(&a);
    assert!(d.abs() > 0.0);
    let solve = |b: [f64; 3]| -> [f64; 3] {
        core::array::from_fn(|j| {
            let mut m = a;
            for (row, v) in m.iter_mut().zip(b) {
                row[j] = v;
            }
            det3(&m) / d
        })
    };
    let (mut total, mut per) = (vec![], [vec![], vec![], vec![]]);
    for (s, x) in run.samples.iter().zip(&estimates) {
        if s.t < run.move_end_s {
            continue;
        }
        let q = solve([s.root_strain, s.mid_strain, s.w_tip]);
        let mut est = 0.0;
        for (i, share) in per.iter_mut().enumerate() {
            let estimate = if i < DESIGN_MODES {
                x[1 + i] as f64
            } else {
                0.0
            };
            let err = n.root_strain_coef[i] * (estimate - q[i]);
            share.push(err);
            est += n.root_strain_coef[i] * estimate;
        }
        total.push(est - s.root_strain);
    }
    let rms = |v: &[f64]| 1e6 * (v.iter().map(|x| x * x).sum::<f64>() / v.len() as f64).sqrt();
    Loss {
        total_rms: rms(&total),
        total_peak: 1e6 * total.iter().fold(0.0f64, |m, e| m.max(e.abs())),
        per_mode_rms: [rms(&per[0]), rms(&per[1]), rms(&per[2])],
    }
}

#[test]
fn what_the_observer_loses_after_the_move_by_sensor_and_by_mode() {
    // The shipped instruments (a 16384-count encoder, a 24-bit converter, 0.5 ue of gauge
    // noise), then each made near ideal in turn: the noise at 0.01 ue, the encoder 64 times
    // finer, both. (Not the noise off: a converter whose code stays put for ten ticks is a
    // frozen gauge to the drive's monitor, and a beam this still at rest reads so.)
    let shipped = SensorConfig::default();
    let fine = model_core::EncoderSpec {
        counts_per_rev: shipped.encoder.counts_per_rev * 64,
        counter_bits: 32,
        ..shipped.encoder
    };
    let cases = [
        ("shipped instruments", shipped),
        (
            "gauge noise 0.01 ue",
            SensorConfig {
                strain_noise_std: 0.01e-6,
                ..shipped
            },
        ),
        (
            "encoder 64 times finer",
            SensorConfig {
                encoder: fine,
                ..shipped
            },
        ),
        (
            "both",
            SensorConfig {
                strain_noise_std: 0.01e-6,
                encoder: fine,
                ..shipped
            },
        ),
    ];
    eprintln!("root strain estimate error after the move, ue: RMS (peak); by mode, RMS");
    let show = |name: &str, l: &Loss| {
        eprintln!(
            "  {name:24} {:.3} ({:.2}); mode 1 {:.3}, mode 2 {:.3}, mode 3 (unobserved) {:.3}",
            l.total_rms, l.total_peak, l.per_mode_rms[0], l.per_mode_rms[1], l.per_mode_rms[2]
        );
    };
    let aluminium = BeamParams::aluminium();
    let losses: Vec<Loss> = cases
        .iter()
        .map(|(name, sensors)| {
            let l = loss_on(aluminium, *sensors, true);
            show(name, &l);
            l
        })
        .collect();
    // The model it runs: the beam's EI a fifth off the observer's, the shipped instruments.
    // On the model's stiffness a model that far off costs more than the instruments do
    // (measured 2026-11-27: 1.00 and 1.48 ue RMS, against 0.86 on its own model); with the
    // stiffness identified at the start of the move the observer runs on the beam's, and the
    // model's error costs about nothing (0.85 and 0.88 ue).
    for ei in [1.2, 0.8] {
        let plant = BeamParams {
            ei_nm2: ei * aluminium.ei_nm2,
            ..aluminium
        };
        let fixed = loss_on(plant, shipped, false);
        show(&format!("EI x{ei}, model's stiffness"), &fixed);
        let found = loss_on(plant, shipped, true);
        show(&format!("EI x{ei}, identified"), &found);
        assert!(fixed.total_rms > 1.1 * losses[0].total_rms, "EI x{ei}");
        assert!(found.total_rms < 1.1 * losses[0].total_rms, "EI x{ei}");
    }
    // Ideal sensors leave the observed modes' error smaller than the shipped ones do, and the
    // encoder's count is part of what the second mode's estimate loses: read 64 times
    // finer by the same observer (designed no finer than the reference encoder resolves,
    // `ANGLE_NOISE_FLOOR_RAD`), that error falls by a fifth (measured 2026-11-28: 0.44 to
    // 0.35 ue; 0.48 to 0.36 before the observer expected the left-out modes' strain as the
    // reference state moves). An observer designed on the finer encoder's own quantisation took it to
    // 0.05 ue (2026-11-26), and followed the encoder so closely that soft, loaded beams off
    // its model rang on without end.
    for m in 0..DESIGN_MODES {
        assert!(
            losses[3].per_mode_rms[m] < losses[0].per_mode_rms[m],
            "mode {}",
            m + 1
        );
    }
    assert!(losses[2].per_mode_rms[1] < 0.85 * losses[0].per_mode_rms[1]);
}

/// With the true state fed to the law (`--true-state`, what the observer costs), the law
/// acts on the plant's state: its estimate of the hub angle and rate, made each tick from
/// the last tick's true state by the model's one-tick prediction, matches the plant's, on a
/// beam a fifth off the model, where the observer's own estimate does not.
#[test]
fn the_law_fed_the_true_state_acts_on_the_plants_state() {
    let nominal = BeamParams::aluminium();
    let plant = BeamParams {
        ei_nm2: 0.8 * nominal.ei_nm2,
        jm_kgm2: 1.2 * nominal.jm_kgm2,
        ..nominal
    };
    let hub_errors = |true_state: bool| {
        let (run, estimates) =
            observed_or_fed(plant, nominal, SensorConfig::default(), true_state, true);
        let rate = 1 + DESIGN_MODES;
        let (mut angle, mut omega) = (0.0f64, 0.0f64);
        for (s, x) in run.samples.iter().zip(&estimates) {
            angle = angle.max((x[0] as f64 - s.theta).abs());
            omega = omega.max((x[rate] as f64 - s.omega).abs());
        }
        // The hub's largest change of rate over a tick.
        let step = run
            .samples
            .windows(2)
            .map(|w| (w[1].omega - w[0].omega).abs())
            .fold(0.0, f64::max);
        (angle.to_degrees(), omega, step)
    };
    let (fed_angle, fed_omega, step) = hub_errors(true);
    let (obs_angle, obs_omega, _) = hub_errors(false);
    eprintln!(
        "largest hub error: fed {fed_angle:.2e} deg, {fed_omega:.2e} rad/s; \
         observed {obs_angle:.2e} deg, {obs_omega:.2e} rad/s; hub rate step {step:.2e} rad/s"
    );
    // One tick's prediction errs by what the model's acceleration misses over a tick: less
    // than the hub's largest change of rate in a tick (the model's Jm is a fifth off, and its
    // two modes leave the third's share of the hub's acceleration out; measured, 74 % of
    // that change), and the angle by half a tick's worth of that, well under 0.01 deg ...
    assert!(fed_angle < 0.01 && fed_omega < step);
    // ... where the observer, reading an encoder step of 0.022 deg and the gauge, is off by
    // several times more.
    assert!(obs_angle > 5.0 * fed_angle && obs_omega > 5.0 * fed_omega);
}

/// The true root strain's RMS about its mean from 1.5 to 3.5 s after a 15 deg move at the
/// shortest time on the aluminium beam, under `law`, with the gauge's noise all but off, ue.
fn ringing_at_rest(law: Law) -> f64 {
    let m = model(BeamParams::aluminium());
    // A gauge without noise would read one code on end and latch the frozen-gauge fault.
    let quiet = SensorConfig {
        strain_noise_std: 1e-9,
        ..SensorConfig::default()
    };
    let shaper = common::shipped().shaper(law.kind(), 0.0);
    let opts = SimOptions {
        duration_s: 3.5,
        motion: Motion {
            from_rad: -7.5f32.to_radians(),
            to_rad: 7.5f32.to_radians(),
            shortest: true,
            shaper,
            ..Motion::default()
        },
        sensors: quiet,
        ..SimOptions::default()
    };
    let run = beam_sim::sim::simulate(&m, law, &opts).unwrap();
    assert!(run.breakdown.is_none() && run.faults.is_empty());
    let rest: Vec<f64> = run
        .samples
        .iter()
        .filter(|s| s.t >= 1.5)
        .map(|s| s.root_strain * 1e6)
        .collect();
    let mean = rest.iter().sum::<f64>() / rest.len() as f64;
    (rest.iter().map(|e| (e - mean).powi(2)).sum::<f64>() / rest.len() as f64).sqrt()
}

#[test]
fn at_rest_smc_modal_reads_the_encoders_count_as_an_interval_and_the_beam_stays_still() {
    // With the gauge silent, what moves the beam at rest is the encoder: the hub sits within
    // a count, and a reading that flips between two, taken as a point, moves the estimate
    // and the torque each time. smc-modal reads it at rest as the count's interval; lqg reads
    // the point. With the interval the beam's ringing at rest must stay under the gauge's
    // own noise on a rig (0.5 ue: the loop adds less than its sensor can see), and under half
    // what the point reading leaves (measured 2026-11-27: 0.24 against 0.80 ue; 0.72 ue for
    // smc-modal reading the point).
    let smc_modal = <model_core::SmcModalGains as model_core::LawGains>::START;
    let interval = ringing_at_rest(Law::SmcModal(smc_modal));
    let point = ringing_at_rest(Law::Lqg(HAND_PICKED_LQG));
    eprintln!("ringing at rest: smc-modal {interval:.3} ue, lqg {point:.3} ue");
    assert!(
        interval < 0.5,
        "smc-modal rings at {interval} ue RMS at rest"
    );
    assert!(
        point > 2.0 * interval,
        "lqg rings at {point} ue RMS at rest"
    );
}

/// The parts a sweep's drive may know of its beam (`beam sweep --drive-knows`) make up the
/// whole design: a drive that knows every part runs, to the bit, as the drive built on the
/// beam, and one that knows none as the drive built on its nominal model. A drive that knows
/// one part runs as neither.
#[test]
fn a_drive_that_knows_every_part_of_the_beam_is_the_drive_built_on_it() {
    let nominal = BeamParams::aluminium();
    let beam = BeamParams {
        ei_nm2: nominal.ei_nm2 * 1.15,
        density_kg_m3: nominal.density_kg_m3 * 0.9,
        jm_kgm2: nominal.jm_kgm2 * 1.1,
        ..nominal
    };
    let (p, n) = (model(beam), model(nominal));
    for kind in [model_core::LawKind::SmcModal, model_core::LawKind::Lqg] {
        let opts = SimOptions {
            duration_s: 1.0,
            motion: Motion {
                shortest: true,
                shaper: common::shipped().shaper(kind, 0.0),
                ..Motion::default()
            },
            ..SimOptions::default()
        };
        let law = common::shipped().law(kind, 0.0).unwrap();
        let torques = |r: SimResult| -> Vec<f64> { r.samples.iter().map(|s| s.torque).collect() };
        let knowing = |known| torques(simulate_knowing(&p, &p, &n, known, law, &opts).unwrap());
        let built_on_beam = torques(simulate_mismatched(&p, &p, law, &opts).unwrap());
        let built_on_nominal = torques(simulate_mismatched(&p, &n, law, &opts).unwrap());
        assert_ne!(built_on_beam, built_on_nominal);
        assert_eq!(knowing(Known::ALL), built_on_beam);
        assert_eq!(knowing(Known::NONE), built_on_nominal);
        let parts = [
            Known {
                observer: true,
                ..Known::NONE
            },
            Known {
                kalman: true,
                ..Known::NONE
            },
            Known {
                regulator: true,
                ..Known::NONE
            },
            Known {
                reference: true,
                ..Known::NONE
            },
        ];
        for part in parts {
            let run = knowing(part);
            assert!(run != built_on_beam && run != built_on_nominal, "{part:?}");
        }
    }
}

/// The stiffness smc-modal's drive, built on the aluminium beam, identifies on `plant` over
/// a move of `deg` at the planner's shortest time, as a factor on the model's.
fn identified(plant: BeamParams, deg: f32) -> f32 {
    identified_at(plant, deg, 0.0)
}

/// [`identified`] with `payload_kg` at the tip of both the beam and the drive's model, and
/// the table's rows at that payload.
fn identified_at(plant: BeamParams, deg: f32, payload_kg: f32) -> f32 {
    identified_over(plant, deg, payload_kg, None)
}

/// [`identified_at`], the move over `time_s` (`None`: the planner's shortest).
fn identified_over(plant: BeamParams, deg: f32, payload_kg: f32, time_s: Option<f32>) -> f32 {
    1.0 + adapted(plant, deg, payload_kg, time_s).identifier.stiffness
}

/// What smc-modal's identifier found of `plant` in [`identified_over`]'s move, and what the
/// law took from it, 0.3 s after the move's start.
fn adapted(plant: BeamParams, deg: f32, payload_kg: f32, time_s: Option<f32>) -> Adaptation {
    let nominal = BeamParams {
        tip_mass_kg: payload_kg as f64,
        ..BeamParams::aluminium()
    };
    let plant = BeamParams {
        tip_mass_kg: payload_kg as f64,
        ..plant
    };
    let (p, n) = (model(plant), model(nominal));
    let kind = model_core::LawKind::SmcModal;
    let opts = SimOptions {
        duration_s: 0.3,
        idle_ticks: 0,
        motion: Motion {
            from_rad: 0.0,
            to_rad: deg.to_radians(),
            shortest: time_s.is_none(),
            time_s: time_s.unwrap_or(Motion::default().time_s),
            shaper: common::shipped().shaper(kind, payload_kg),
            ..Motion::default()
        },
        ..SimOptions::default()
    };
    let settings = ControllerSettings {
        theta_home_rad: opts.motion.from_rad,
        ..settings_for(&n, &opts.sensors)
    };
    let law = common::shipped().law(kind, payload_kg).unwrap();
    let spline = opts.motion.plan(&Limits::for_law(&n, &law)).unwrap();
    let built = ControlLaw::try_build(law, opts.sensors.instruments().on(&n)).unwrap();
    let mut rec =
        common::Recording::new(Controller::try_build(settings, built, spline.clone()).unwrap());
    run_with(Plant::new(p), &mut rec, &spline, &opts).unwrap();
    rec.controller.law_state().lqg.adaptation
}

/// smc-modal's identifier fits the beam's stiffness against its density, `EI / rho` against
/// the model's (the ratio its frequencies go with), in the move's first 0.1 s: within 2 % on
/// beams whose EI or density is 20 % off the model, within 4 % at the soft corner (both off
/// the other way), within 10 % at the stiff corner, where the step's bias is corrected too
/// far; the model's own beam is read as the model (within the dead band), with a payload
/// too.
///
/// The one Gauss-Newton step reads every beam off the model stiffer than it is (measured
/// without its correction, `IDENTIFY_STEP_BIAS`: by 2-4 % with EI or density 20 % off, 7-9 %
/// at the soft corner, 2-6 % at the stiff corner). Corrected, measured (2026-11-28): 0.2-1.2 %
/// stiff with EI or density 20 % off, 1.6-3.2 % stiff at the soft corner, 3.3-9.2 % soft at
/// the stiff corner (1.36-1.45 for 1.5, the most at 15 deg). Until the identifier expected
/// the strain of the modes the design leaves out as the reference state moves (the hub's
/// swing on the beam, the centrifugal load, a payload's coupling:
/// `beam_model::lqg::OmittedStrain`), it expected them at the rigid reference's
/// acceleration, as the beam's exact statics: then 0.4-1.5 %, 1.8-3.7 % and 3.1-7.3 %, and
/// the model's own beam read 2.3-2.6 % soft at 50 g. Before it expected them at all, it read
/// that strain as softness, which offset about 1 % of the bias (and read the model's own
/// beam 5-9 % softer with 50 g at the tip).
#[test]
fn the_drive_identifies_the_beams_stiffness_at_the_start_of_a_move() {
    let nominal = BeamParams::aluminium();
    let cases = [
        (1.0, 1.0, 0.0),
        (0.8, 1.0, 0.02),
        (1.2, 1.0, 0.02),
        (1.0, 1.2, 0.02),
        (0.8, 1.2, 0.04),
        (1.2, 0.8, 0.10),
    ];
    for deg in [15.0, 45.0, 90.0, 180.0] {
        for (ei, rho, within) in cases {
            let beam = BeamParams {
                ei_nm2: nominal.ei_nm2 * ei,
                density_kg_m3: nominal.density_kg_m3 * rho,
                ..nominal
            };
            let found = identified(beam, deg);
            let truth = (ei / rho) as f32;
            assert!(
                (found / truth - 1.0).abs() <= within,
                "{deg} deg, EI x{ei}, density x{rho}: found {found}, the beam's {truth}"
            );
        }
        // With a payload the model's own beam reads as the model: its root strain under the
        // move is the design's modes' and what it expects of the others, the payload's
        // coupling of the modes' accelerations included. Measured: 1 (the dead band) at 25
        // and 50 g (0.974-0.977 at 50 g when the others' were expected at the rigid
        // reference's acceleration, as the beam's exact statics).
        for (payload, within) in [(0.025, 0.005), (0.05, 0.005)] {
            let found = identified_at(nominal, deg, payload);
            assert!(
                (found - 1.0).abs() <= within,
                "{deg} deg, the model's own beam with {payload} kg: found {found}"
            );
        }
    }
}

/// Once the identifier has found the beam's stiffness, smc-modal's moving regulator is the
/// one designed on a beam of that stiffness (`LqgDesign::k_move_compliance`): each gain
/// within a fifth of its change from the model's, or 2 % of itself, of the regulator the
/// host designs on that beam. The slope in the compliance is the secant between the
/// identifier's range's ends, so this checks it at the beams between, against designs it
/// was not made from. Measured: within 6 % of the change and 1 % of the gain (the first
/// mode's angle gain on the stiffest beam found, x1.31).
#[test]
fn the_moving_regulator_is_the_one_designed_on_the_beam_identified() {
    let nominal = BeamParams::aluminium();
    let kind = model_core::LawKind::SmcModal;
    let law = common::shipped().law(kind, 0.0).unwrap();
    let instruments = SensorConfig::default().instruments();
    let design_on = |ei: f64| -> LqgDesign {
        let beam = BeamParams {
            ei_nm2: nominal.ei_nm2 * ei,
            ..nominal
        };
        *ControlLaw::try_build(law, instruments.on(&model(beam)))
            .unwrap()
            .observer_design()
            .unwrap()
    };
    let on_model = design_on(1.0);
    for (ei, rho) in [(0.8, 1.0), (1.0, 1.2), (1.2, 1.0), (1.0, 0.8)] {
        let beam = BeamParams {
            ei_nm2: nominal.ei_nm2 * ei,
            density_kg_m3: nominal.density_kg_m3 * rho,
            ..nominal
        };
        let a = adapted(beam, 90.0, 0.0, None);
        let found = 1.0 + a.identifier.stiffness;
        // The blend has converged by 0.3 s.
        assert!((1.0 + a.stiffness - found).abs() < 1e-3);
        let on_found = design_on(found as f64);
        // The moving share and its filter gain, in one row.
        let gains = |k: &[f32; MAX_STATES], filter: f32| -> [f32; MAX_STATES + 1] {
            core::array::from_fn(|i| if i < MAX_STATES { k[i] } else { filter })
        };
        let adapted = gains(&a.k_move, a.k_move_filter);
        let (want, was) = (
            gains(&on_found.k_move, on_found.k_move_filter),
            gains(&on_model.k_move, on_model.k_move_filter),
        );
        for i in 0..=MAX_STATES {
            assert!(
                (adapted[i] - want[i]).abs() <= 0.2 * (was[i] - want[i]).abs() + 0.02 * want[i].abs(),
                "EI x{ei}, density x{rho}, found x{found}: gain {i} is {}, on that beam {}, on the model {}",
                adapted[i],
                want[i],
                was[i]
            );
        }
    }
}

/// A move that starts too gently to bend the beam much (90 deg over 2 s: its first 0.1 s
/// give the fit 1e-8 of summed squared sensitivity, against 3e-7 and more for the planner's
/// shortest moves from 5 deg) is not fitted (`MIN_FIT_SENSITIVITY`): the drive runs it on the model, on
/// a beam 20 % softer too. Fitted, such moves read the model's own beam 3-9 % off.
#[test]
fn a_move_too_gentle_to_fit_runs_on_the_model() {
    let nominal = BeamParams::aluminium();
    for ei in [1.0, 0.8] {
        let beam = BeamParams {
            ei_nm2: nominal.ei_nm2 * ei,
            ..nominal
        };
        assert_eq!(identified_over(beam, 90.0, 0.0, Some(2.0)), 1.0, "EI x{ei}");
        // The same move at the shortest time is fitted, and off the model on the softer
        // beam.
        let shortest = identified_over(beam, 90.0, 0.0, None);
        assert!(ei == 1.0 || shortest < 0.9, "EI x{ei}: {shortest}");
    }
}

/// The identifier's `G = Mqq^-1 h`, found on the drive from the reference beam's numbers,
/// against the model's own matrices, at each payload.
#[test]
fn the_identifier_finds_the_clamped_coupling_from_the_reference_beam() {
    use model_core::law::LawPlant;
    use model_core::law::{clamped_coupling, DesignOptions};
    let options = DesignOptions {
        identify: true,
        ..DesignOptions::default()
    };
    for payload in [0.0, 0.025, 0.05] {
        let params = BeamParams {
            tip_mass_kg: payload,
            ..BeamParams::aluminium()
        };
        let m: ModalModel<2> = ModalModel::try_build(&Beam::try_build(params).unwrap()).unwrap();
        let design = SensorConfig::default()
            .instruments()
            .on(&m)
            .lqg(
                &HAND_PICKED_LQG.weights(options),
                model_core::DEFAULT_TS_S as f64,
            )
            .unwrap()
            .unwrap();
        let g = clamped_coupling(&design);
        for (i, found) in g.iter().enumerate() {
            let exact: f64 = (0..2).map(|l| m.mqq_inv[i][l] * m.h[l]).sum();
            assert!(
                (*found as f64 / exact - 1.0).abs() < 0.01,
                "{payload} kg, mode {i}: {found} against {exact}"
            );
        }
    }
}
