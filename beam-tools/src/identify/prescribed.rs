//! The beam with its hub prescribed from a log: the flexible part driven by the logged hub
//! motion (torque and motor errors cannot leak in), through the sensor's lag and, for a
//! noisy hub, a Kalman observer of the strain; what calibration fits the beam on.

use super::hub::*;
use crate::identify::calibrate::Log;
use beam_sim::plant::Plant;
use model_core::{Beam, BeamParams, ModalModel};

/// The beam driven by a prescribed hub, sample by sample.
#[derive(Clone, Debug, PartialEq)]
pub struct Prescribed {
    /// The beam signal the model implies for the log's sensor (root strain or tip
    /// deflection, SI, gauge scale 1).
    pub beam_signal: Vec<f64>,
    /// Mid-span strain the model implies.
    pub mid_strain: Vec<f64>,
    /// The part of the torque the beam (and tip) take from the hub that their flexing
    /// adds to their rigid inertia's `(Mtt - Jm) alpha`: `q'Sq alpha + h'q'' + 2 omega
    /// q'S q'`, N m. With the ratio EI/rho held it scales with the density (no tip mass).
    pub flex_torque_nm: Vec<f64>,
    /// The beam's (and tip's) rigid inertia about the hub's axis, `Mtt - Jm`, kg m^2.
    pub beam_inertia_kgm2: f64,
}

/// Longest strain delay [`strain_delay`] looks for, s.
pub const MAX_STRAIN_DELAY_S: f64 = 0.1;

/// How long the logged root strain lags the strain `params`' beam gives on the logged hub,
/// s: the lag within +-[`MAX_STRAIN_DELAY_S`] at which the two correlate best, refined
/// between samples by a parabola through the best three (negative: the log's strain leads),
/// over the samples where the hub moves. The hub's acceleration drives the strain there, so
/// a model whose frequencies are a few percent off still peaks near the gauge's lag, the
/// nearer the shorter the move: on a beam 15 % stiffer than the model, 2 ms early for a
/// 0.5 s move logged 40 ms late, 7 ms early for a 1 s move on a beam 10 % stiffer (in the
/// ringing during a long move the model's phase drifts by its frequency's error). So
/// `calibrate` finds it again on its result. `None` if the model breaks down or either
/// strain is flat.
pub fn strain_delay<const N: usize>(params: &BeamParams, log: &Log) -> Option<f64> {
    let hub = HubMotion::of(log, hub_window_s(params));
    let model = prescribed::<N>(params, log, &hub)?.beam_signal;
    // Only while the hub moves: there the strain is what the hub's acceleration forces, and
    // a model a few percent off in frequency has the phase right; in the ringing after, its
    // phase drifts by the frequency's error and pulls the peak.
    let peak = hub.omega.iter().fold(0.0f64, |a, w| a.max(w.abs()));
    let moving: Vec<bool> = hub.omega.iter().map(|w| w.abs() > 0.05 * peak).collect();
    let logged = &log.beam_signal;
    let dt = log.t[1] - log.t[0];
    let max_lag = ((MAX_STRAIN_DELAY_S / dt).round() as usize).min(logged.len() / 4);
    // Correlation of model[k] with logged[k + lag], over the samples both have.
    let corr = |lag: isize| -> f64 {
        let (mut sxy, mut sxx, mut syy) = (0.0, 0.0, 0.0);
        for (k, &m) in model.iter().enumerate() {
            let j = k as isize + lag;
            if !moving[k] || j < 0 || j as usize >= logged.len() {
                continue;
            }
            let s = logged[j as usize];
            sxy += m * s;
            sxx += m * m;
            syy += s * s;
        }
        if sxx > 0.0 && syy > 0.0 {
            sxy / (sxx * syy).sqrt()
        } else {
            f64::NAN
        }
    };
    let lags: Vec<(isize, f64)> = (-(max_lag as isize)..=max_lag as isize)
        .map(|l| (l, corr(l)))
        .collect();
    let (i, &(best, c0)) = lags
        .iter()
        .enumerate()
        .filter(|(_, (_, c))| c.is_finite())
        .max_by(|a, b| a.1 .1.total_cmp(&b.1 .1))?;
    // A parabola through the best and its neighbours (at the search's edge, the best alone).
    let vertex = match (i.checked_sub(1).and_then(|j| lags.get(j)), lags.get(i + 1)) {
        (Some(&(_, cm)), Some(&(_, cp))) if (cm - 2.0 * c0 + cp) < 0.0 => {
            0.5 * (cm - cp) / (cm - 2.0 * c0 + cp)
        }
        _ => 0.0,
    };
    Some((best as f64 + vertex) * dt)
}

/// Below this a lag found in a log is taken as none: model error and noise move the
/// correlation's peak by about a sample on logs with no lag, s.
pub const STRAIN_DELAY_FLOOR_S: f64 = 0.003;

/// The delay to take `log`'s beam signal back by, s ([`Log::strain_advanced`]), and what to
/// say of it (naming `file`): `given` if given, else found by [`strain_delay`] on `params`.
/// A lag within [`STRAIN_DELAY_FLOOR_S`] (or a sample and a half), or a signal that leads
/// the model's, which no sensor can, is not taken out.
pub fn sensor_lag<const N: usize>(
    params: &BeamParams,
    log: &Log,
    file: &str,
    given: Option<f64>,
) -> (f64, Option<String>) {
    if let Some(d) = given {
        return (d, None);
    }
    let Some(found) = strain_delay::<N>(params, log) else {
        return (0.0, None);
    };
    let dt = log.t[1] - log.t[0];
    if found.abs() < STRAIN_DELAY_FLOOR_S.max(1.5 * dt) {
        return (0.0, None);
    }
    let what = log.sensor.name();
    if found < 0.0 {
        return (0.0, Some(format!(
            "{file}: the {what} leads the model's (on the logged hub) by {:.3} s, which a sensor cannot; not applied (check that its column and the angle's share a clock, or give --strain-delay)",
            -found
        )));
    }
    (found, Some(format!(
        "{file}: the {what} lags the model's (on the logged hub) by {found:.3} s (a sensor amplifier's filter, or a sample clock behind the encoder's); its readings are taken {found:.3} s later (give --strain-delay 0 to keep them as logged)"
    )))
}

/// The root strain of the beam driven by the logged hub motion, at each sample, with an
/// `N`-mode model of `params`; `None` if the parameters are invalid or the model breaks
/// down. The hub's rate and acceleration come from [`HubMotion::of`] with
/// [`hub_window_s`].
pub fn replay_prescribed<const N: usize>(params: &BeamParams, log: &Log) -> Option<Vec<f64>> {
    let hub = HubMotion::of(log, hub_window_s(params));
    prescribed::<N>(params, log, &hub).map(|p| p.beam_signal)
}

/// The beam of an `N`-mode model of `params` driven by `hub` (sampled at `log`'s times);
/// `None` if the parameters are invalid or the model breaks down. RK4, four steps a
/// sample, with the hub's rate and acceleration interpolated linearly between samples.
pub fn prescribed<const N: usize>(
    params: &BeamParams,
    log: &Log,
    hub: &HubMotion,
) -> Option<Prescribed> {
    prescribed_observed::<N>(params, log, hub, None)
}

/// How [`prescribed_observed`] corrects the beam's state with the logged root strain.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StrainObserver {
    /// The gauge's scale (logged strain over the model's).
    pub gauge_scale: f64,
    /// The prescribed hub's acceleration error, RMS, rad/s^2 (the process noise).
    pub alpha_err: f64,
    /// The gauge's noise and the model's strain error, RMS (the measurement noise).
    pub strain_err: f64,
}

/// The beam's modal state `(q, q')` one sample of `dt` on: RK4 in four sub-steps, with the
/// hub's rate and acceleration at each stage from `hub(x)`, `x` the fraction of the sample.
pub(super) fn sample_step<const N: usize>(
    plant: &Plant<N>,
    mut q: [f64; N],
    mut qd: [f64; N],
    dt: f64,
    hub: impl Fn(f64) -> (f64, f64),
) -> ([f64; N], [f64; N]) {
    let h = dt / 4.0;
    let add = |x: &[f64; N], d: &[f64; N], s: f64| -> [f64; N] {
        core::array::from_fn(|i| x[i] + s * d[i])
    };
    for j in 0..4 {
        let f = |q: &[f64; N], qd: &[f64; N], stage: f64| {
            let (w, a) = hub((j as f64 + stage) / 4.0);
            plant.flex_acceleration(q, qd, w, a)
        };
        let (k1q, k1v) = (qd, f(&q, &qd, 0.0));
        let (q2, v2) = (add(&q, &k1q, h / 2.0), add(&qd, &k1v, h / 2.0));
        let (k2q, k2v) = (v2, f(&q2, &v2, 0.5));
        let (q3, v3) = (add(&q, &k2q, h / 2.0), add(&qd, &k2v, h / 2.0));
        let (k3q, k3v) = (v3, f(&q3, &v3, 0.5));
        let (q4, v4) = (add(&q, &k3q, h), add(&qd, &k3v, h));
        let (k4q, k4v) = (v4, f(&q4, &v4, 1.0));
        q = core::array::from_fn(|i| {
            q[i] + h / 6.0 * (k1q[i] + 2.0 * k2q[i] + 2.0 * k3q[i] + k4q[i])
        });
        qd = core::array::from_fn(|i| {
            qd[i] + h / 6.0 * (k1v[i] + 2.0 * k2v[i] + 2.0 * k3v[i] + k4v[i])
        });
    }
    (q, qd)
}

/// The steady-state Kalman gain of the beam's modal state `[q, q']` (hub at rest, at the
/// log's sample period `dt`) for the root strain, with the hub's acceleration error as
/// the process noise. `None` if the iteration does not settle.
pub(super) fn strain_kalman_gain<const N: usize>(
    plant: &Plant<N>,
    dt: f64,
    obs: &StrainObserver,
    row: &[f64; N],
) -> Option<Vec<f64>> {
    let n = 2 * N;
    // One sample of the linear beam (RK4, four sub-steps) from `x` under a held hub
    // acceleration `a`.
    let advance = |x: &[f64], a: f64| -> Vec<f64> {
        let q: [f64; N] = core::array::from_fn(|i| x[i]);
        let v: [f64; N] = core::array::from_fn(|i| x[N + i]);
        let (q, v) = sample_step(plant, q, v, dt, |_| (0.0, a));
        q.iter().chain(v.iter()).copied().collect()
    };
    // A: columns are the unit states advanced; B: the response to a unit acceleration.
    let mut a = vec![vec![0.0; n]; n];
    for j in 0..n {
        let mut e = vec![0.0; n];
        e[j] = 1.0;
        let col = advance(&e, 0.0);
        for i in 0..n {
            a[i][j] = col[i];
        }
    }
    let b = advance(&vec![0.0; n], 1.0);
    let hrow: Vec<f64> = (0..n)
        .map(|i| if i < N { obs.gauge_scale * row[i] } else { 0.0 })
        .collect();
    let r = obs.strain_err.max(1e-12).powi(2);
    let qn = obs.alpha_err.powi(2);
    let mut p = vec![vec![0.0; n]; n];
    let mut gain = vec![0.0; n];
    for _ in 0..20_000 {
        // Predict: P = A P A' + B B' qn.
        let ap: Vec<Vec<f64>> = (0..n)
            .map(|i| {
                (0..n)
                    .map(|j| (0..n).map(|k| a[i][k] * p[k][j]).sum())
                    .collect()
            })
            .collect();
        let mut pp = vec![vec![0.0; n]; n];
        for i in 0..n {
            for j in 0..n {
                pp[i][j] = (0..n).map(|k| ap[i][k] * a[j][k]).sum::<f64>() + b[i] * b[j] * qn;
            }
        }
        // Update with the strain.
        let ph: Vec<f64> = (0..n)
            .map(|i| (0..n).map(|j| pp[i][j] * hrow[j]).sum())
            .collect();
        let s: f64 = (0..n).map(|i| hrow[i] * ph[i]).sum::<f64>() + r;
        let new_gain: Vec<f64> = ph.iter().map(|x| x / s).collect();
        for i in 0..n {
            for j in 0..n {
                p[i][j] = pp[i][j] - new_gain[i] * ph[j];
            }
        }
        let change = new_gain
            .iter()
            .zip(&gain)
            .map(|(x, y)| (x - y).abs())
            .fold(0.0, f64::max);
        let size = new_gain.iter().map(|x| x.abs()).fold(0.0, f64::max);
        gain = new_gain;
        if change <= 1e-10 * size.max(1e-300) {
            return gain.iter().all(|g| g.is_finite()).then_some(gain);
        }
    }
    None
}

/// [`prescribed`], with the beam's state corrected at each sample by the logged root strain
/// through a steady-state Kalman gain when `observer` is given: the beam's vibration that
/// the prescribed hub does not carry (a hub chattering within an encoder count) is then in
/// the state, and in the torque it takes from the hub.
pub fn prescribed_observed<const N: usize>(
    params: &BeamParams,
    log: &Log,
    hub: &HubMotion,
    observer: Option<StrainObserver>,
) -> Option<Prescribed> {
    let plant = beam_plant::<N>(params)?;
    prescribed_on(&plant, log, hub, observer)
}

/// The plant of an `N`-mode model of `params`; `None` if they are not a beam.
pub fn beam_plant<const N: usize>(params: &BeamParams) -> Option<Plant<N>> {
    let model = ModalModel::<N>::try_build(&Beam::try_build(*params).ok()?).ok()?;
    Some(Plant::new(model))
}

/// [`prescribed_observed`] on a plant already built (the model's build is about half of a
/// replay's cost; a fit that drives several logs' beams with one parameter set builds it
/// once).
pub fn prescribed_on<const N: usize>(
    plant: &Plant<N>,
    log: &Log,
    hub: &HubMotion,
    observer: Option<StrainObserver>,
) -> Option<Prescribed> {
    let model = &plant.model;
    let dt = log.t[1] - log.t[0];
    let row = log.sensor.coef(&plant.model);
    // A gain that does not settle leaves the beam uncorrected.
    let gain = observer
        .as_ref()
        .and_then(|obs| strain_kalman_gain(plant, dt, obs, &row));
    let (omega, alpha) = (&hub.omega, &hub.alpha);
    let mut torque = Vec::with_capacity(log.t.len());
    let mut mid = Vec::with_capacity(log.t.len());
    let (mut q, mut qd) = ([0.0f64; N], [0.0f64; N]);
    let mut eps = Vec::with_capacity(log.t.len());
    for k in 0..log.t.len() {
        if let (Some(gain), Some(obs)) = (&gain, &observer) {
            let innovation =
                log.beam_signal[k] - obs.gauge_scale * model_core::linalg::dot(&row, &q);
            for i in 0..N {
                q[i] += gain[i] * innovation;
                qd[i] += gain[N + i] * innovation;
            }
        }
        eps.push(model_core::linalg::dot(&row, &q));
        mid.push(model_core::linalg::dot(&plant.model.mid_strain_coef, &q));
        let (w, a) = (omega[k], alpha[k]);
        let qdd = plant.flex_acceleration(&q, &qd, w, a);
        let sq = model_core::linalg::mat_vec(&model.s, &q);
        torque.push(
            model_core::linalg::dot(&q, &sq) * a
                + model_core::linalg::dot(&model.h, &qdd)
                + 2.0 * w * model_core::linalg::dot(&sq, &qd),
        );
        // The hub's rate and acceleration are interpolated linearly to the next sample's:
        // held instead, they would reach the beam half a sample late, which on the other
        // rig's loaded strip (500 Hz) read as 7 % less modal damping than it had.
        let (w1, a1) = if k + 1 < log.t.len() {
            (omega[k + 1], alpha[k + 1])
        } else {
            (w, a)
        };
        (q, qd) = sample_step(plant, q, qd, dt, |x| (w + x * (w1 - w), a + x * (a1 - a)));
        if !q.iter().chain(qd.iter()).all(|x| x.is_finite()) {
            return None;
        }
    }
    Some(Prescribed {
        beam_signal: eps,
        mid_strain: mid,
        flex_torque_nm: torque,
        beam_inertia_kgm2: model.mtt - model.beam.params().jm_kgm2,
    })
}
