//! The LQG design's tests: its numerics against closed forms (the matrix exponential of a
//! rotation, a scalar Riccati equation), the sampled model against the model's hub-free
//! frequencies, the reference beam against the beam the rigid torque drives, and the
//! closed loop's poles under the design's options (the feedback's low-pass, the moving
//! regulator and its rate by payload, a stiffer regulator at rest).

use super::*;
use crate::beam::{Beam, BeamParams};

/// The sensors' noise the tests design with.
const NOISE: SensorNoise = SensorNoise {
    theta_rad: 1e-4,
    encoder_step_rad: 0.0,
    strain: 1e-6,
};

fn model() -> ModalModel<3> {
    model_of(BeamParams::aluminium())
}

/// The modal model of `params` on `N` modes.
fn model_of<const N: usize>(params: BeamParams) -> ModalModel<N> {
    ModalModel::try_build(&Beam::try_build(params).unwrap()).unwrap()
}

#[test]
fn the_matrix_exponential_of_a_rotation_is_a_rotation() {
    // exp([[0, w], [-w, 0]] t) = [[cos, sin], [-sin, cos]] (w t): an independent fact.
    let mut a = ZERO;
    let wt = 2.3;
    a[0][1] = wt;
    a[1][0] = -wt;
    let e = expm(&a, 2);
    assert!((e[0][0] - libm::cos(wt)).abs() < 1e-12);
    assert!((e[0][1] - libm::sin(wt)).abs() < 1e-12);
    assert!((e[1][0] + libm::sin(wt)).abs() < 1e-12);
}

#[test]
fn the_riccati_solution_of_a_scalar_system_is_the_closed_form_root() {
    // x+ = a x + u, cost q x^2 + u^2: X = q + a^2 X / (1 + X), a quadratic in X.
    let (a, q) = (1.2, 0.5);
    let mut am = ZERO;
    am[0][0] = a;
    let mut g = ZERO;
    g[0][0] = 1.0;
    let mut h = ZERO;
    h[0][0] = q;
    let x = dare(&am, &g, &h, 1).unwrap()[0][0];
    // X^2 + (1 - q - a^2) X - q = 0
    let b = 1.0 - q - a * a;
    let root = (-b + (b * b + 4.0 * q).sqrt()) / 2.0;
    assert!((x - root).abs() < 1e-10, "{x} vs {root}");
}

#[test]
fn the_sampled_model_has_the_pinned_frequencies_and_a_rigid_mode() {
    // Without damping or friction the eigenvalues of Ad are exp(+-j w ts) of the
    // continuous poles: two at 1 (the rigid body) and, per mode, a pair on the unit
    // circle at the pinned (hub-free) frequency, which the modal model finds by its own
    // eigen-solver. So Ad's trace is 2 + sum 2 cos(w ts).
    let m: ModalModel<3> = model_of(BeamParams {
        damping_ratio: 0.0,
        viscous_nms: 0.0,
        ..BeamParams::aluminium()
    });
    let ts = 1e-3;
    let (ad, _) = sampled_with(&m, &mass_inverse(&m).unwrap(), ts).unwrap();
    let trace: f64 = (0..8).map(|i| ad[i][i]).sum();
    let expected: f64 = 2.0
        + m.pinned_hz
            .iter()
            .map(|f| 2.0 * (2.0 * core::f64::consts::PI * f * ts).cos())
            .sum::<f64>();
    assert!((trace - expected).abs() < 1e-9, "{trace} vs {expected}");
}

#[test]
fn the_reference_beam_is_the_beam_the_rigid_torque_drives() {
    // The torque Mtt a on the whole (hub-free) model moves it as the rigid body moves
    // under a, plus the reference beam swinging on it: the hub at theta_r + ref_hub . q.
    // Checked against the sampled torque-driven model (`sampled_with`, the observer's),
    // through a bang-coast-bang acceleration held over each tick, and after it.
    let m: ModalModel<2> = model_of(BeamParams {
        viscous_nms: 0.0,
        ..BeamParams::aluminium()
    });
    let ts = 1e-3;
    let minv = mass_inverse(&m).unwrap();
    let (ad, bd) = sampled_with(&m, &minv, ts).unwrap();
    let mut d = LqgDesign::ZERO;
    reference_beam(&m, &minv, ts, &mut d);
    let (mut x, mut z) = ([0.0f64; 6], [0.0f64; 4]);
    let (mut theta, mut omega) = (0.0f64, 0.0f64);
    let mut worst = [0.0f64; 2];
    let mut peak = [0.0f64; 2];
    for k in 0..400 {
        let a = match k {
            0..60 => 200.0,
            60..120 => 0.0,
            120..180 => -200.0,
            _ => 0.0,
        };
        let u = m.mtt * a;
        x = core::array::from_fn(|i| (0..6).map(|j| ad[i][j] * x[j]).sum::<f64>() + bd[i] * u);
        z = core::array::from_fn(|i| {
            (0..4).map(|j| d.ref_ad[i][j] as f64 * z[j]).sum::<f64>() + d.ref_bd[i] as f64 * a
        });
        theta += omega * ts + 0.5 * a * ts * ts;
        omega += a * ts;
        let hub = |q: &[f64]| (0..2).map(|i| d.ref_hub[i] as f64 * q[i]).sum::<f64>();
        let want = [
            theta + hub(&z[..2]),
            z[0],
            z[1],
            omega + hub(&z[2..]),
            z[2],
            z[3],
        ];
        for i in 0..6 {
            // Angles and modes, then rates.
            let g = usize::from(i >= 3);
            worst[g] = worst[g].max((x[i] - want[i]).abs());
            peak[g] = peak[g].max(x[i].abs());
        }
    }
    // The beam swung: its modes moved the hub by more than the match's error.
    assert!(z.iter().any(|v| v.abs() > 1e-6), "{z:?}");
    // Equal up to the f32 rounding of the reference beam's coefficients.
    assert!(worst[0] < 1e-5 * peak[0], "{worst:?} of {peak:?}");
    assert!(worst[1] < 1e-5 * peak[1], "{worst:?} of {peak:?}");
}

#[test]
fn the_closed_loop_and_the_observer_are_stable() {
    let m = model();
    let w = LqgWeights {
        kp: 60.0,
        kd: 2.0,
        ki: 200.0,
        sigma_nm: 0.5,
        move_rate: 0.0,
        ..moving_weights()
    };
    let noise = NOISE;
    // A design holds the first two modes; the whole model is refused.
    assert_eq!(design(&m, &w, &noise, 1e-3), Err(LqgError::Modes));
    let d = design(
        &leading_modes::<3, DESIGN_MODES>(&m).unwrap(),
        &w,
        &noise,
        1e-3,
    )
    .unwrap();
    let nx = MAX_STATES;
    // The whole sampled matrix, its angle column the unit vector.
    let ad = |i: usize, j: usize| match j {
        0 => f64::from(u8::from(i == 0)),
        _ => d.ad[i][j - 1] as f64,
    };
    // Iterate the closed loop from a unit start (the state, the integral, the filtered
    // torque: the command `-K [x; z; f]` moves the filter, which drives the plant) and
    // the observer error (I - L C) A: both must decay.
    let mut x = [1.0f64; MAX_STATES + 2];
    let mut e = [1.0f64; MAX_STATES];
    for _ in 0..20_000 {
        let u: f64 = -(0..nx).map(|j| d.k[j] as f64 * x[j]).sum::<f64>()
            - d.ki as f64 * x[nx]
            - d.k_filter as f64 * x[nx + 1];
        let f = x[nx + 1] + FILTER * (u - x[nx + 1]);
        let nxt: [f64; MAX_STATES + 2] = core::array::from_fn(|i| {
            if i < nx {
                (0..nx).map(|j| ad(i, j) * x[j]).sum::<f64>() + d.bd[i] as f64 * f
            } else if i == nx {
                x[nx] + 1e-3 * x[0]
            } else {
                f
            }
        });
        x = nxt;
        let pred: [f64; MAX_STATES] =
            core::array::from_fn(|i| (0..nx).map(|j| ad(i, j) * e[j]).sum::<f64>());
        let y0 = pred[0];
        let y1: f64 = (0..DESIGN_MODES)
            .map(|i| d.strain_coef[i] as f64 * pred[1 + i])
            .sum();
        e = core::array::from_fn(|i| pred[i] - d.l[i][0] as f64 * y0 - d.l[i][1] as f64 * y1);
    }
    let norm = |v: &[f64]| v.iter().map(|a| a.abs()).fold(0.0, f64::max);
    assert!(norm(&e) < 1e-3, "observer error {:?}", e);
    assert!(norm(&x) < 1e-3, "closed loop {:?}", x);
}

/// The feedback low-pass's step the tests design with: the drive's, 5/32 (27 Hz).
const FILTER: f64 = 0.156_25;

/// The spectral radius of the sampled closed loop (no integral) on `[x; f]`, `f` the
/// feedback low-pass's state, with the gains `k` on `x` and `kf` on `f`: the command
/// `u = -k x - kf f` makes `f+ = (1 - a) f + a u` and `x+ = A x + B f+`. From the
/// growth of `M^n`: Gelfand's formula, `||M^n||^(1/n) -> rho(M)`.
fn spectral_radius(d: &LqgDesign, k: &[f64; MAX_STATES], kf: f64) -> f64 {
    const S: usize = MAX_STATES + 1;
    let nx = S;
    let a = |i: usize, j: usize| match j {
        0 => f64::from(u8::from(i == 0)),
        _ => d.ad[i][j - 1] as f64,
    };
    // The filter's row: `f+ = (1 - a) f - a (k x + kf f)`.
    let frow: [f64; S] = core::array::from_fn(|j| {
        if j < MAX_STATES {
            -FILTER * k[j]
        } else {
            1.0 - FILTER - FILTER * kf
        }
    });
    let m: [[f64; S]; S] = core::array::from_fn(|i| {
        core::array::from_fn(|j| {
            if i == MAX_STATES {
                frow[j]
            } else {
                let own = if j < MAX_STATES { a(i, j) } else { 0.0 };
                own + d.bd[i] as f64 * frow[j]
            }
        })
    });
    super::closed_loop::spectral_radius(&m, nx)
}

/// smc-modal's weights: a moving regulator at 12 1/s, the same at every payload, and
/// the same `kp` at rest.
fn moving_weights() -> LqgWeights {
    LqgWeights {
        kp: 200.0,
        kd: 1.0,
        ki: 0.0,
        kq: 1e4,
        sigma_nm: 3.0,
        move_rate: 12.0,
        count_interval: false,
        identify: false,
        feedback_lowpass: FILTER,
        move_rate_unloaded: 0.0,
        move_rate_payload_kg: 0.0,
        rest_kp: 0.0,
    }
}

#[test]
fn the_moving_rate_falls_from_the_unloaded_one_to_its_own_at_the_payload_given() {
    let w = LqgWeights {
        move_rate_unloaded: 18.0,
        move_rate_payload_kg: 0.025,
        ..moving_weights()
    };
    assert_eq!(w.move_rate_at(0.0), 18.0);
    assert!((w.move_rate_at(0.0125) - 15.0).abs() < 1e-12);
    assert_eq!(w.move_rate_at(0.025), 12.0);
    assert_eq!(w.move_rate_at(0.05), 12.0);
    // No moving regulator, or none faster unloaded: the rate is `move_rate` throughout.
    let none = LqgWeights {
        move_rate: 0.0,
        ..w
    };
    assert_eq!(none.move_rate_at(0.0), 0.0);
    let slower = LqgWeights {
        move_rate_unloaded: 6.0,
        ..w
    };
    assert_eq!(slower.move_rate_at(0.0), 12.0);
    // The design takes the rate at its model's payload: unloaded, the design of a
    // moving regulator at 18 1/s, every pole of its loop left of -18 1/s.
    let m = leading_modes::<3, DESIGN_MODES>(&model()).unwrap();
    assert_eq!(m.beam.params().tip_mass_kg, 0.0);
    let noise = NOISE;
    let d = design(&m, &w, &noise, 1e-3).unwrap();
    let fixed = LqgWeights {
        move_rate: 18.0,
        move_rate_unloaded: 0.0,
        ..w
    };
    assert_eq!(d, design(&m, &fixed, &noise, 1e-3).unwrap());
    let moving: [f64; MAX_STATES] = core::array::from_fn(|i| (d.k[i] + d.k_move[i]) as f64);
    let r = spectral_radius(&d, &moving, (d.k_filter + d.k_move_filter) as f64);
    assert!(r < (-18.0f64 * 1e-3).exp(), "{r}");
}

#[test]
fn a_stiffer_rest_regulator_leaves_the_moving_one_as_it_was() {
    let m = leading_modes::<3, DESIGN_MODES>(&model()).unwrap();
    let noise = NOISE;
    let w = LqgWeights {
        rest_kp: 400.0,
        ..moving_weights()
    };
    let d = design(&m, &w, &noise, 1e-3).unwrap();
    let one = |w: LqgWeights| design(&m, &w, &noise, 1e-3).unwrap();
    // At rest: the regulator on kp 400 alone.
    let rest = one(LqgWeights {
        kp: 400.0,
        move_rate: 0.0,
        rest_kp: 0.0,
        ..w
    });
    assert_eq!((d.k, d.k_filter), (rest.k, rest.k_filter));
    // Moving: the moving regulator on kp 200, as without `rest_kp`.
    let plain = one(LqgWeights { rest_kp: 0.0, ..w });
    for i in 0..MAX_STATES {
        let (a, b) = (d.k[i] + d.k_move[i], plain.k[i] + plain.k_move[i]);
        assert!((a - b).abs() <= 1e-5 * b.abs().max(1.0), "{i}: {a} {b}");
    }
    // The hub's static stiffness at rest, `k_theta / (1 + kf)`, is the stiffer one's.
    let stiffness = |d: &LqgDesign| d.k[0] / (1.0 + d.k_filter);
    assert!(stiffness(&d) > 1.5 * stiffness(&plain));
    // Without a moving regulator `rest_kp` is not used.
    let single = |rest_kp| {
        one(LqgWeights {
            move_rate: 0.0,
            rest_kp,
            ..w
        })
    };
    assert_eq!(single(400.0).k, single(0.0).k);
}

#[test]
fn the_moving_regulator_holds_every_pole_left_of_its_rate() {
    let m = leading_modes::<3, DESIGN_MODES>(&model()).unwrap();
    let ts = 1e-3;
    let noise = NOISE;
    for rate in [5.0, 20.0] {
        let w = LqgWeights {
            sigma_nm: 2.0,
            move_rate: rate,
            ..moving_weights()
        };
        let d = design(&m, &w, &noise, ts).unwrap();
        let base: [f64; MAX_STATES] = core::array::from_fn(|i| d.k[i] as f64);
        let moving: [f64; MAX_STATES] = core::array::from_fn(|i| (d.k[i] + d.k_move[i]) as f64);
        // Inside the circle of radius e^(-rate ts): every pole left of -rate. The loop's
        // own regulator is not (its slowest poles are near -11 1/s), so the bound is the
        // design's doing.
        let bound = (-rate * ts).exp();
        let (kf, kfm) = (d.k_filter as f64, (d.k_filter + d.k_move_filter) as f64);
        let (rb, rm) = (
            spectral_radius(&d, &base, kf),
            spectral_radius(&d, &moving, kfm),
        );
        assert!(rm < bound, "rate {rate}: {rm} against {bound}");
        assert!(rb > (-20.0 * ts).exp(), "the regulator alone: {rb}");
        // With no rate there is nothing to add.
        let d0 = design(
            &m,
            &LqgWeights {
                move_rate: 0.0,
                ..w
            },
            &noise,
            ts,
        )
        .unwrap();
        assert_eq!(d0.k_move, [0.0; MAX_STATES]);
        assert_eq!(d0.k_move_filter, 0.0);
        assert_eq!(d0.k, d.k);
        assert_eq!(d0.k_filter, d.k_filter);
        // Without a filter (a step of 1, the command applied as it is) the filter's
        // state carries nothing and has no gain.
        let bare = design(
            &m,
            &LqgWeights {
                feedback_lowpass: 1.0,
                ..w
            },
            &noise,
            ts,
        )
        .unwrap();
        assert_eq!((bare.k_filter, bare.k_move_filter), (0.0, 0.0));
    }
}

#[test]
fn on_its_own_model_the_loop_has_the_regulators_poles_and_the_observers() {
    // The separation principle, an independent fact: with the observer on the plant it
    // models, the loop's poles are the state feedback's (on `[x; f]`) and the observer
    // error's (`(I - L C) A`), so its radius is the larger of the two.
    let m = leading_modes::<3, DESIGN_MODES>(&model()).unwrap();
    let w = LqgWeights {
        rest_kp: 400.0,
        move_rate_unloaded: 18.0,
        move_rate_payload_kg: 0.025,
        ..moving_weights()
    };
    let d = design(&m, &w, &NOISE, 1e-3).unwrap();
    let ad = |i: usize, j: usize| match j {
        0 => f64::from(u8::from(i == 0)),
        _ => d.ad[i][j - 1] as f64,
    };
    let mut err = [[0.0; MAX_STATES]; MAX_STATES];
    for i in 0..MAX_STATES {
        for j in 0..MAX_STATES {
            // Row i of (I - L C) A: C's rows are the angle and the strain.
            let c = |r: usize, l: usize| match r {
                0 => f64::from(u8::from(l == 0)),
                _ if (1..=DESIGN_MODES).contains(&l) => d.strain_coef[l - 1] as f64,
                _ => 0.0,
            };
            err[i][j] = ad(i, j)
                - (0..MAX_STATES)
                    .map(|l| (0..2).map(|r| d.l[i][r] as f64 * c(r, l)).sum::<f64>() * ad(l, j))
                    .sum::<f64>();
        }
    }
    let observer = super::closed_loop::spectral_radius(&err, MAX_STATES);
    for moving in [false, true] {
        let wt = f64::from(u8::from(moving));
        let k: [f64; MAX_STATES] =
            core::array::from_fn(|i| d.k[i] as f64 + wt * d.k_move[i] as f64);
        let kf = d.k_filter as f64 + wt * d.k_move_filter as f64;
        let regulator = spectral_radius(&d, &k, kf);
        let setting = LoopSetting {
            move_weight: wt,
            gain: 1.0,
            lowpass: FILTER,
            integral: false,
            stiffness: 1.0,
        };
        let whole = loop_radius(&m, &d, setting, 1e-3).unwrap();
        let both = regulator.max(observer);
        assert!(
            (whole - both).abs() < 1e-5,
            "moving {moving}: {whole} against {regulator} and {observer}"
        );
        assert!(whole < 1.0);
    }
}

/// The moving regulator moved by the compliance (`LqgDesign::k_move_compliance`) keeps the
/// degree of stability it is designed for (18 1/s here) on every beam the identifier may
/// find, from 2/3 to 3/2 of the model's stiffness: measured 26.9-46.7 1/s for the state
/// feedback on the beam of that stiffness, where the model's own gains leave 16.6 1/s on
/// the softest. And a fit that is wrong by the whole range (the gains moved for one end,
/// the beam the model's) still leaves the model's loop that fast: 19.8-33.4 1/s.
#[test]
fn the_moving_regulator_moved_by_the_compliance_keeps_its_rate_on_the_beam_found() {
    let m = leading_modes::<3, DESIGN_MODES>(&model()).unwrap();
    let rate = 18.0;
    let w = LqgWeights {
        rest_kp: 400.0,
        identify: true,
        move_rate: rate,
        ..moving_weights()
    };
    let d = design(&m, &w, &NOISE, 1e-3).unwrap();
    let decay = |r: f64| -libm::log(r) / 1e-3;
    let moved = |c: f32| -> ([f64; MAX_STATES], f64) {
        (
            core::array::from_fn(|i| (d.k[i] + d.k_move[i] + c * d.k_move_compliance[i]) as f64),
            (d.k_filter + d.k_move_filter + c * d.k_move_filter_compliance) as f64,
        )
    };
    let (plain, plain_f) = moved(0.0);
    let mut unmoved_softest = f64::INFINITY;
    for stiffness in [2.0 / 3.0, 0.75, 0.9, 1.1, 1.25, 1.5] {
        let (k, kf) = moved((1.0 / stiffness - 1.0) as f32);
        let beam = design(&stiffened(&m, stiffness), &w, &NOISE, 1e-3).unwrap();
        let on_beam = decay(spectral_radius(&beam, &k, kf));
        let wrong = decay(spectral_radius(&d, &k, kf));
        assert!(
            on_beam > rate,
            "stiffness x{stiffness}: {on_beam} 1/s on its beam"
        );
        assert!(
            wrong > rate,
            "stiffness x{stiffness}: {wrong} 1/s on the model"
        );
        unmoved_softest = unmoved_softest.min(decay(spectral_radius(&beam, &plain, plain_f)));
    }
    // Without the move, the softest beam's loop is slower than designed.
    assert!(unmoved_softest < rate, "{unmoved_softest}");
}
