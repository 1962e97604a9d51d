//! The nonlinear plant against facts it did not produce: conservation of energy and angular
//! momentum, the hub-free frequency of the linearised model, Southwell's law for a spinning
//! beam, and agreement of the fast RK4 integrator with the adaptive DOP853 reference.

use beam_sim::plant::{Plant, State};
use model_core::{Beam, BeamParams, ModalModel};

fn plant<const N: usize>(params: BeamParams) -> Plant<N> {
    Plant::new(ModalModel::<N>::try_build(&Beam::try_build(params).unwrap()).unwrap())
}

fn rk4_run<const N: usize>(
    p: &Plant<N>,
    x0: State<N>,
    h: f64,
    t_end: f64,
    mut each: impl FnMut(f64, &State<N>),
) {
    let steps = (t_end / h).round() as usize;
    let mut x = x0;
    each(0.0, &x);
    for k in 1..=steps {
        x = p.rk4_step(&x, 0.0, h);
        each(k as f64 * h, &x);
    }
}

/// Largest relative drift of energy and of angular momentum over a free, lossless run.
fn drift<const N: usize>(p: &Plant<N>, x0: State<N>, h: f64, t_end: f64) -> (f64, f64) {
    let (e0, l0) = (p.energy(&x0), p.angular_momentum(&x0));
    let (mut de, mut dl) = (0.0f64, 0.0f64);
    rk4_run(p, x0, h, t_end, |_, x| {
        de = de.max(((p.energy(x) - e0) / e0).abs());
        dl = dl.max(((p.angular_momentum(x) - l0) / l0).abs());
    });
    (de, dl)
}

fn spinning_deformed() -> State<3> {
    State {
        theta: 0.0,
        omega: 6.0,
        q: [8e-3, -1e-3, 2e-4],
        qd: [0.05, 0.0, 0.0],
    }
}

#[test]
fn free_lossless_beam_conserves_energy_and_angular_momentum() {
    // With b = 0, zeta = 0 and no torque the Lagrangian has no explicit time and theta is
    // cyclic, so T + V and dT/dtheta' are exact invariants of the equations. Whatever drift
    // remains is integration error: it must shrink as h^4 for RK4.
    let p = plant::<3>(BeamParams::aluminium()).lossless();
    let x0 = spinning_deformed();
    let (e1, l1) = drift(&p, x0, 2.5e-4, 3.0);
    let (e2, l2) = drift(&p, x0, 1.25e-4, 3.0);
    assert!(
        e1 < 1e-5 && l1 < 1e-5,
        "drift at 0.25 ms: energy {e1:e}, momentum {l1:e}"
    );
    // Fourth order: halving h divides the error by about 16 (allow 8 for the constant).
    assert!(e2 < e1 / 8.0 || e2 < 1e-12, "energy drift {e1:e} -> {e2:e}");
    assert!(
        l2 < l1 / 8.0 || l2 < 1e-12,
        "momentum drift {l1:e} -> {l2:e}"
    );
}

#[test]
fn reference_integrator_is_exact_on_an_oscillator() {
    // y'' = -100 y from y = 1 at rest: y(1) = cos 10. Guards the ODE crate itself (its 0.6.2
    // release fails this by ten orders of magnitude).
    use ode_solvers::{DVector, Dop853, System};
    struct Oscillator;
    impl System<f64, DVector<f64>> for Oscillator {
        fn system(&self, _t: f64, y: &DVector<f64>, dy: &mut DVector<f64>) {
            dy[0] = y[1];
            dy[1] = -100.0 * y[0];
        }
    }
    let mut s = Dop853::new(
        Oscillator,
        0.0,
        1.0,
        1.0,
        DVector::from_vec(vec![1.0, 0.0]),
        1e-10,
        1e-12,
    );
    s.integrate().unwrap();
    let y = s.y_out().last().unwrap();
    assert!(
        (y[0] - 10f64.cos()).abs() < 1e-8,
        "{} vs {}",
        y[0],
        10f64.cos()
    );
    assert!((y[1] + 10.0 * 10f64.sin()).abs() < 1e-7);
}

#[test]
fn adaptive_reference_conserves_to_its_tolerance() {
    let p = plant::<3>(BeamParams::aluminium()).lossless();
    let x0 = spinning_deformed();
    let (e0, l0) = (p.energy(&x0), p.angular_momentum(&x0));
    let mut x = x0;
    for _ in 0..100 {
        x = p.dop853(&x, 0.0, 0.01, 1e-10, 1e-12).unwrap();
    }
    assert!(((p.energy(&x) - e0) / e0).abs() < 1e-8);
    assert!(((p.angular_momentum(&x) - l0) / l0).abs() < 1e-8);
}

/// Mean frequency (Hz) of a signal from its upward zero crossings, linearly interpolated.
fn crossing_frequency(samples: &[(f64, f64)]) -> f64 {
    let ups: Vec<f64> = samples
        .windows(2)
        .filter(|w| w[0].1 < 0.0 && w[1].1 >= 0.0)
        .map(|w| w[0].0 + (w[1].0 - w[0].0) * (-w[0].1) / (w[1].1 - w[0].1))
        .collect();
    assert!(ups.len() >= 5, "too few oscillations");
    (ups.len() - 1) as f64 / (ups[ups.len() - 1] - ups[0])
}

#[test]
fn free_hub_vibrates_at_the_pinned_frequency() {
    // The linearised hub-free system's first flexible frequency, from the generalised
    // eigenproblem, must be what the nonlinear plant does at small amplitude.
    let p = plant::<2>(BeamParams::aluminium()).lossless();
    let x0 = State {
        theta: 0.0,
        omega: 0.0,
        q: [1e-5, 0.0],
        qd: [0.0, 0.0],
    };
    // Project onto mode 1 by watching the tip minus the rigid motion is not needed: the second
    // mode is barely excited by a first-mode shape, and zero crossings pick the dominant one.
    let mut trace = Vec::new();
    rk4_run(&p, x0, 1e-4, 3.0, |t, x| trace.push((t, x.q[0])));
    let f = crossing_frequency(&trace);
    let expect = p.model.pinned_hz[0];
    assert!(
        (f - expect).abs() < 2e-3 * expect,
        "measured {f} Hz, eigenvalue {expect} Hz"
    );
    // And it is not the clamped frequency: the free hub matters (9.8 vs 5.5 Hz).
    assert!((f - p.model.clamped_hz[0]).abs() > 0.5 * p.model.clamped_hz[0]);
}

#[test]
fn spinning_beam_follows_southwells_law() {
    // Southwell: omega^2 = omega_0^2 + kappa Omega^2 for a beam spun at a constant rate Omega.
    // For these matrices the in-plane coefficient is kappa = -S11/M11 = -(Mqq + 2G)_11/M11:
    // foreshortening (-2G) stiffens, the in-plane centrifugal term (-Mqq) softens by exactly 1.
    // A huge hub inertia holds the rate constant; the nonlinear plant must show the law.
    let params = BeamParams {
        jm_kgm2: 1e4,
        ..BeamParams::aluminium()
    };
    let p = plant::<1>(params).lossless();
    let m = &p.model;
    let kappa = -m.s[0][0] / m.mqq[0][0];
    let stiffening = -2.0 * m.g[0][0] / m.mqq[0][0];
    assert!((kappa - (stiffening - 1.0)).abs() < 1e-12);
    assert!(
        kappa > 0.0,
        "with this hub radius foreshortening wins: the frequency must rise"
    );
    let w0 = 2.0 * std::f64::consts::PI * m.clamped_hz[0];
    let mut measured = Vec::new();
    for spin in [0.0, 20.0, 30.0] {
        let x0 = State {
            theta: 0.0,
            omega: spin,
            q: [1e-5],
            qd: [0.0],
        };
        let mut trace = Vec::new();
        rk4_run(&p, x0, 1e-4, 3.0, |t, x| trace.push((t, x.q[0])));
        let w = 2.0 * std::f64::consts::PI * crossing_frequency(&trace);
        let predicted = (w0 * w0 + kappa * spin * spin).sqrt();
        assert!(
            (w - predicted).abs() < 2e-3 * predicted,
            "spin {spin}: {w} vs {predicted} rad/s"
        );
        measured.push((spin * spin, w * w));
    }
    // omega^2 is linear in Omega^2 with slope kappa.
    let slope = (measured[2].1 - measured[1].1) / (measured[2].0 - measured[1].0);
    assert!(
        (slope - kappa).abs() < 0.02 * kappa.abs(),
        "slope {slope} vs kappa {kappa}"
    );
}

#[test]
fn rk4_agrees_with_the_adaptive_reference_under_a_torque_profile() {
    // A zero-order-held torque profile like a slew's: both integrators restart at every tick.
    for modes in [1usize, 4] {
        let (a, b) = match modes {
            1 => {
                let p = plant::<1>(BeamParams::aluminium());
                let (a, b) = run_profile(&p);
                (pick(&a), pick(&b))
            }
            _ => {
                let p = plant::<4>(BeamParams::aluminium());
                let (a, b) = run_profile(&p);
                (pick(&a), pick(&b))
            }
        };
        for (x, y) in a.iter().zip(&b) {
            assert!(
                (x.0 - y.0).abs() < 1e-7,
                "{modes} modes: theta {} vs {}",
                x.0,
                y.0
            );
            assert!(
                (x.1 - y.1).abs() < 1e-8,
                "{modes} modes: q1 {} vs {}",
                x.1,
                y.1
            );
        }
    }
}

fn pick<const N: usize>(xs: &[State<N>]) -> Vec<(f64, f64)> {
    xs.iter().map(|x| (x.theta, x.q[0])).collect()
}

fn run_profile<const N: usize>(p: &Plant<N>) -> (Vec<State<N>>, Vec<State<N>>) {
    let ts = 1e-3;
    let (mut x, mut y) = (State::<N>::at_rest(0.0), State::<N>::at_rest(0.0));
    let (mut xs, mut ys) = (Vec::new(), Vec::new());
    for k in 0..600 {
        let t = k as f64 * ts;
        let tau = if t < 0.35 {
            3.0 * (2.0 * std::f64::consts::PI * t / 0.35).sin()
        } else {
            0.0
        };
        for _ in 0..4 {
            x = p.rk4_step(&x, tau, ts / 4.0);
        }
        y = p.dop853(&y, tau, ts, 1e-11, 1e-13).unwrap();
        xs.push(x);
        ys.push(y);
    }
    (xs, ys)
}

#[test]
fn with_the_hub_prescribed_the_beam_obeys_the_same_equations() {
    // The flexible rows of the full equations of motion, with the hub's acceleration the
    // full model computes, are what the prescribed-hub replay integrates: for a spinning,
    // deformed beam under any torque the two give the same modal accelerations.
    let p = plant::<3>(BeamParams::aluminium());
    let x = spinning_deformed();
    for tau in [-5.0, 0.0, 2.5] {
        let full = p.derivative(&x, tau);
        let flex = p.flex_acceleration(&x.q, &x.qd, x.omega, full.omega);
        for (i, (a, b)) in flex.iter().zip(&full.qd).enumerate() {
            assert!(
                (a - b).abs() <= 1e-9 * b.abs().max(1.0),
                "mode {i}: {a} vs {b}"
            );
        }
    }
}

#[test]
fn near_rest_coulomb_friction_needs_the_stable_step_and_stops_the_hub_with_it() {
    // Friction of 0.06 N m smoothed over 1e-3 rad/s: with no torque, a hub turning at
    // 5e-4 rad/s must come to rest. At the plant's stable step RK4 brings it there; at a
    // quarter of a 500 Hz sample (0.5 ms), outside RK4's stability region for this stiff
    // term (h lambda about 4 > 2.78), the rate chatters instead of dying out.
    let p = plant::<3>(BeamParams {
        coulomb_nm: 0.06,
        ..BeamParams::aluminium()
    });
    let h_stable = p.stable_step_s();
    assert!(h_stable < 0.5e-3 / 2.78, "{h_stable}");
    let run = |h: f64| {
        let mut x = State::<3>::at_rest(0.0);
        x.omega = 5e-4;
        let steps = (0.1 / h).round() as usize;
        let mut late = 0.0f64;
        for k in 0..steps {
            x = p.rk4_step(&x, 0.0, h);
            if k > steps / 2 {
                late = late.max(x.omega.abs());
            }
        }
        late
    };
    let (stable, coarse) = (run(h_stable), run(0.5e-3));
    // At the stable step what is left is the beam's own vibration coupled into the hub
    // (a few 1e-6 rad/s); at 0.5 ms the friction term itself oscillates, tens of times more.
    assert!(
        stable < 2e-5,
        "at the stable step the hub still turns at {stable} rad/s"
    );
    assert!(
        coarse > 10.0 * stable,
        "at 0.5 ms: {coarse} rad/s, at the stable step: {stable} rad/s"
    );
}

#[test]
fn scaling_every_mass_stiffness_friction_and_the_torque_together_changes_no_motion() {
    // Dimensional analysis: the beam's equation depends on EI/rho only, the strain on the
    // curvature, and the hub's equation is linear in Jm, the beam's inertia, the friction and
    // the torque. So a beam with Jm, density, EI, both friction terms (and the torque
    // limit) times s, driven by the torque times s, moves exactly as the original: the
    // reason calibration from one rig's logs cannot tell a torque scale error from the
    // masses and stiffness without one absolute fact (beam_tools::identify::split).
    let base = BeamParams {
        coulomb_nm: 0.03,
        viscous_nms: 0.002,
        ..BeamParams::aluminium()
    };
    let s = 1.37;
    let scaled = BeamParams {
        jm_kgm2: base.jm_kgm2 * s,
        density_kg_m3: base.density_kg_m3 * s,
        ei_nm2: base.ei_nm2 * s,
        viscous_nms: base.viscous_nms * s,
        coulomb_nm: base.coulomb_nm * s,
        torque_limit_nm: base.torque_limit_nm * s,
        ..base
    };
    let (a, b) = (plant::<3>(base), plant::<3>(scaled));
    let torque = |t: f64| 0.3 * (7.0 * t).sin() + 0.1 * (31.0 * t).cos();
    let (mut xa, mut xb) = (State::<3>::at_rest(0.1), State::<3>::at_rest(0.1));
    let h = 1e-4;
    let mut worst = (0.0f64, 0.0f64);
    for k in 0..10_000 {
        let u = torque(k as f64 * h);
        xa = a.rk4_step(&xa, a.saturate(u), h);
        xb = b.rk4_step(&xb, b.saturate(s * u), h);
        let (oa, ob) = (a.outputs(&xa), b.outputs(&xb));
        worst.0 = worst.0.max((xa.theta - xb.theta).abs());
        worst.1 = worst.1.max((oa.root_strain - ob.root_strain).abs());
    }
    let moved = (xa.theta - 0.1).abs();
    assert!(moved > 0.05, "the hub must move: {moved} rad");
    assert!(worst.0 < 1e-12 && worst.1 < 1e-15, "{worst:?}");
    // And a torque scale without the masses does change it (the test can fail).
    let c = plant::<3>(BeamParams {
        torque_limit_nm: scaled.torque_limit_nm,
        ..base
    });
    let mut xc = State::<3>::at_rest(0.1);
    let mut xa = State::<3>::at_rest(0.1);
    for k in 0..10_000 {
        let u = torque(k as f64 * h);
        xa = a.rk4_step(&xa, a.saturate(u), h);
        xc = c.rk4_step(&xc, c.saturate(s * u), h);
    }
    assert!((xa.theta - xc.theta).abs() > 1e-3);
}

#[test]
fn friction_that_differs_by_direction_takes_the_links_momentum_at_its_own_rate_each_way() {
    // A link coasting with no torque and no viscous friction loses angular momentum,
    // `L = (Mtt + q'Sq) omega + h'q'`, to Coulomb friction alone: dL/dt = -(Fc + Fa) while
    // the hub turns positive, Fc - Fa while it turns negative (outside the smooth sign's
    // 1e-3 rad/s band, which the hub does not enter here).
    let (fc, fa): (f64, f64) = (0.05, 0.02);
    let p = plant::<3>(BeamParams {
        coulomb_nm: fc,
        coulomb_asym_nm: fa,
        viscous_nms: 0.0,
        ..BeamParams::aluminium()
    });
    let m = p.model;
    let momentum = |x: &State<3>| {
        let sq = model_core::linalg::mat_vec(&m.s, &x.q);
        (m.mtt + model_core::linalg::dot(&x.q, &sq)) * x.omega
            + model_core::linalg::dot(&m.h, &x.qd)
    };
    let h = p.stable_step_s().min(1e-4);
    let span = 0.3;
    for (omega0, force) in [(2.0f64, fc + fa), (-2.0, fc - fa)] {
        let mut x = State::<3>::at_rest(0.0);
        x.omega = omega0;
        let l0 = momentum(&x);
        let steps = (span / h).round() as usize;
        for _ in 0..steps {
            x = p.rk4_step(&x, 0.0, h);
            assert!(x.omega * omega0.signum() > 0.01, "the hub stopped: {x:?}");
        }
        let rate = (momentum(&x) - l0) / (steps as f64 * h);
        assert!(
            (rate + omega0.signum() * force).abs() < 1e-6 * force,
            "turning {omega0} rad/s: dL/dt {rate} N m, friction {force} N m"
        );
    }
    // Parameters with more difference than friction are refused, naming the field.
    let bad = BeamParams {
        coulomb_nm: 0.01,
        coulomb_asym_nm: 0.02,
        ..BeamParams::aluminium()
    };
    assert_eq!(Beam::try_build(bad).unwrap_err().field, "coulomb_asym_nm");
}
