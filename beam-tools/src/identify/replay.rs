//! The model against a log (`beam replay`): the beam driven by the logged hub angle (the hub
//! prescribed, so torque and motor errors cannot leak into the flexible part) and, for the
//! hub itself, by the logged torque open loop; with the figures that say how well the model
//! explains the log.

use crate::identify::calibrate::{replay as replay_torque, BeamSensor, Log, Windows};
use crate::io::params_file::Sensors;
use beam_sim::plant::Plant;
use model_core::{Beam, BeamParams, ModalModel};
use serde::Serialize;

/// How well a model explains a log.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ReplayReport {
    /// RMS hub-angle error of the open-loop torque replay over the move and settling, deg.
    pub hub_rms_err_deg: f64,
    /// What the log measures the beam with: `root strain` or `tip deflection`.
    pub beam_signal: &'static str,
    /// The unit of the two figures below: `ue` (root strain) or `mm` (tip deflection).
    pub beam_unit: &'static str,
    /// RMS error of the beam's signal with the hub prescribed, over the move and settling.
    pub beam_rms_err: f64,
    /// RMS of the measured signal over the same window (the error's yardstick).
    pub beam_rms_measured: f64,
    /// The error as a fraction of the measured RMS.
    pub beam_rel_err: f64,
    /// The first vibration frequency in the logged beam signal from the end of the move to
    /// the end of the log, Hz.
    pub freq_log_hz: Option<f64>,
    /// The same from the model's (hub prescribed), Hz.
    pub freq_model_hz: Option<f64>,
    /// Why a frequency is missing, if one is: the window after the move too short to hold
    /// two cycles of the vibration, or no vibration in it.
    pub freq_note: Option<String>,
}

/// Why [`vibration_hz`] finds no frequency.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum NoFrequency {
    /// Fewer than 16 samples, or nothing but a line (no vibration).
    Flat,
    /// The signal fits best with fewer than two cycles in the window: its frequency cannot
    /// be told from the window's length (a longer log after the move can).
    WindowTooShort,
}

/// Hub rate and acceleration at each sample, from a local quadratic fit to the logged angle
/// over `half` samples either side (a Savitzky-Golay differentiator: the encoder's steps
/// would make plain differences useless for the acceleration).
pub fn hub_rates(log: &Log, half: usize) -> (Vec<f64>, Vec<f64>) {
    let (_, omega, alpha) = hub_fit(log, half);
    (omega, alpha)
}

/// The local quadratic fit of [`hub_rates`]: angle (smoothed), rate and acceleration.
fn hub_fit(log: &Log, half: usize) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    let n = log.t.len();
    let dt = log.t[1] - log.t[0];
    let mut level = log.theta.clone();
    let mut omega = vec![0.0; n];
    let mut alpha = vec![0.0; n];
    for k in 0..n {
        let lo = k.saturating_sub(half);
        let hi = (k + half).min(n - 1);
        // Least squares of theta = a + b x + c x^2, x in samples from k.
        let (mut s0, mut s1, mut s2, mut s3, mut s4) = (0.0, 0.0, 0.0, 0.0, 0.0);
        let (mut y0, mut y1, mut y2) = (0.0, 0.0, 0.0);
        for j in lo..=hi {
            let x = j as f64 - k as f64;
            let y = log.theta[j];
            s0 += 1.0;
            s1 += x;
            s2 += x * x;
            s3 += x * x * x;
            s4 += x * x * x * x;
            y0 += y;
            y1 += x * y;
            y2 += x * x * y;
        }
        // Solve the 3x3 normal equations by Cramer's rule.
        let det = s0 * (s2 * s4 - s3 * s3) - s1 * (s1 * s4 - s3 * s2) + s2 * (s1 * s3 - s2 * s2);
        if det.abs() < 1e-12 {
            continue;
        }
        let b =
            (s0 * (y1 * s4 - s3 * y2) - y0 * (s1 * s4 - s3 * s2) + s2 * (s1 * y2 - y1 * s2)) / det;
        let c =
            (s0 * (s2 * y2 - y1 * s3) - s1 * (s1 * y2 - y1 * s2) + y0 * (s1 * s3 - s2 * s2)) / det;
        let a =
            (y0 * (s2 * s4 - s3 * s3) - s1 * (y1 * s4 - s3 * y2) + s2 * (y1 * s3 - s2 * y2)) / det;
        level[k] = a;
        omega[k] = b / dt;
        alpha[k] = 2.0 * c / (dt * dt);
    }
    (level, omega, alpha)
}

/// The encoder's step in a logged angle, rad: the span of the distinct angles over the
/// number of steps between them (each gap between neighbours counted in units of the
/// smallest), when every angle lies on that grid within a tenth of a step (an angle printed
/// in rounded decimals, such as 16384 counts a turn logged in degrees to 0.001, is off its
/// grid by up to a few percent of a step). `None` for an angle that is not quantised, or
/// takes fewer than three values.
pub fn encoder_step(theta: &[f64]) -> Option<f64> {
    let mut levels: Vec<f64> = theta.iter().copied().filter(|t| t.is_finite()).collect();
    levels.sort_by(f64::total_cmp);
    levels.dedup();
    if levels.len() < 3 {
        return None;
    }
    let gaps: Vec<f64> = levels.windows(2).map(|w| w[1] - w[0]).collect();
    let smallest = gaps.iter().copied().fold(f64::INFINITY, f64::min);
    if !(smallest.is_finite() && smallest > 0.0) {
        return None;
    }
    let steps: f64 = gaps.iter().map(|g| (g / smallest).round()).sum();
    let (origin, span) = (levels[0], levels[levels.len() - 1] - levels[0]);
    let q = span / steps;
    let on_grid = levels.iter().all(|l| {
        let n = (l - origin) / q;
        (n - n.round()).abs() < 0.1
    });
    (q.is_finite() && q > 0.0 && on_grid).then_some(q)
}

/// Phases (fractions of a step) at which [`requantised`] quantises the angle again.
pub const ENCODER_PHASES: [f64; 8] = [
    -0.4375, -0.3125, -0.1875, -0.0625, 0.0625, 0.1875, 0.3125, 0.4375,
];

/// `log` with its angle smoothed (the quadratic fit over `half` samples either side) and
/// quantised again to steps of `step`, `phase` steps off the log's own grid: another draw of
/// the encoder's error at the same resolution, for seeing how much the results depend on it.
pub fn requantised(log: &Log, half: usize, step: f64, phase: f64) -> Log {
    let (level, _, _) = hub_fit(log, half);
    let origin = log.theta.iter().copied().fold(f64::INFINITY, f64::min);
    let theta = level
        .iter()
        .map(|t| origin + step * (((t - origin) / step + phase).round() - phase))
        .collect();
    Log {
        theta,
        ..log.clone()
    }
}

/// The half-width of the quadratic fit that gives the prescribed hub its rate and
/// acceleration, s: a quarter period of the beam's second clamped mode (analytic, no tip
/// mass), within 5..30 ms. Shorter windows pass the encoder's steps into the acceleration
/// (on a 0.6 m steel strip at 500 Hz, +-5 ms left the true model 4.7 % off the logged root
/// strain, +-15 ms 2.9 %); longer ones smooth away the second mode (on the aluminium beam,
/// whose second mode is at 34 Hz, +-15 ms doubled the error to 2.3 %).
pub fn hub_window_s(params: &BeamParams) -> f64 {
    let p = params;
    let b = model_core::modal::MODE_ROOTS[1];
    let f2 = b * b / (2.0 * core::f64::consts::PI * p.length_m * p.length_m)
        * (p.ei_nm2 / p.rho_kg_m()).sqrt();
    if f2.is_finite() && f2 > 0.0 {
        (0.25 / f2).clamp(HUB_WINDOW_S.0, HUB_WINDOW_S.1)
    } else {
        HUB_WINDOW_S.0
    }
}

/// The prescribed hub's half-width stays within these, s.
pub const HUB_WINDOW_S: (f64, f64) = (0.005, 0.030);

/// The hub's motion taken from a log: rate and acceleration at each sample.
#[derive(Clone, Debug, PartialEq)]
pub struct HubMotion {
    /// Rate, rad/s.
    pub omega: Vec<f64>,
    /// Acceleration, rad/s^2.
    pub alpha: Vec<f64>,
}

impl HubMotion {
    /// From a quadratic fit over `window_s` either side of each sample (at least two samples).
    pub fn of(log: &Log, window_s: f64) -> Self {
        let dt = log.t[1] - log.t[0];
        let half = ((window_s / dt).round() as usize).max(2);
        let (omega, alpha) = hub_rates(log, half);
        Self { omega, alpha }
    }

    /// The RMS difference of the acceleration from `other`'s, rad/s^2.
    pub fn alpha_rms_diff(&self, other: &HubMotion) -> f64 {
        let n = self.alpha.len().max(1) as f64;
        let ss: f64 = self
            .alpha
            .iter()
            .zip(&other.alpha)
            .map(|(a, b)| (a - b).powi(2))
            .sum();
        (ss / n).sqrt()
    }
}

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
fn sample_step<const N: usize>(
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
fn strain_kalman_gain<const N: usize>(
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

/// The dominant vibration frequency of `signal` over `[from, to]` s (times `t`): the
/// frequency of the damped sinusoid plus straight line that fits it best in least squares
/// (variable projection: amplitude, phase and line in closed form for each frequency and
/// decay rate tried), searched around the peak of the detrended periodogram between two
/// cycles over the span and a quarter of the sample rate (at most 200 Hz): a mode slower
/// than two cycles of the window is not seen, and the caller must not ask for one
/// ([`replay_report`] checks the window against the model's first mode).
/// [`NoFrequency::WindowTooShort`] when not even that range exists, [`NoFrequency::Flat`]
/// with fewer than 16 samples or a flat signal. (Mean crossings, used before, counted the
/// gauge's noise as cycles on a small residual; a bare periodogram peak is pulled by the
/// decay and the hub's slow motion.)
pub fn vibration_hz(t: &[f64], signal: &[f64], from: f64, to: f64) -> Result<f64, NoFrequency> {
    let idx: Vec<usize> = (0..t.len())
        .filter(|&k| t[k] >= from && t[k] <= to)
        .collect();
    if idx.len() < 16 {
        return Err(NoFrequency::Flat);
    }
    let ts: Vec<f64> = idx.iter().map(|&k| t[k] - t[idx[0]]).collect();
    let ys: Vec<f64> = idx.iter().map(|&k| signal[k]).collect();
    if !ys.iter().all(|y| y.is_finite()) {
        return Err(NoFrequency::Flat);
    }
    let mut line = crate::identify::lsq::Normal::new(2);
    ts.iter()
        .zip(&ys)
        .for_each(|(x, y)| line.add(&[1.0, *x], *y));
    let yy: f64 = ys.iter().map(|y| y * y).sum();
    if line.solve().is_none_or(|f| f.rss <= 1e-20 * yy) {
        return Err(NoFrequency::Flat);
    }
    let span = ts[ts.len() - 1];
    let dt = span / (ts.len() - 1) as f64;
    let (lo, hi) = (2.0 / span, (0.25 / dt).min(200.0));
    if !(hi > lo) {
        return Err(NoFrequency::WindowTooShort);
    }
    // Residual sum of squares of the best fit of [e^-st cos wt, e^-st sin wt, 1, t].
    let misfit = |f: f64, decay: f64| -> f64 {
        let w = 2.0 * core::f64::consts::PI * f;
        let mut ata = [[0.0f64; 4]; 4];
        let mut atb = [0.0f64; 4];
        let mut bb = 0.0;
        for (x, y) in ts.iter().zip(&ys) {
            let e = (-decay * x).exp();
            let row = [e * (w * x).cos(), e * (w * x).sin(), 1.0, *x];
            for i in 0..4 {
                for j in 0..4 {
                    ata[i][j] += row[i] * row[j];
                }
                atb[i] += row[i] * y;
            }
            bb += y * y;
        }
        match crate::identify::lsq::solve(ata.iter().map(|r| r.to_vec()).collect(), atb.to_vec()) {
            Some(c) => bb - c.iter().zip(&atb).map(|(c, b)| c * b).sum::<f64>(),
            None => f64::INFINITY,
        }
    };
    let decays = [0.0, 0.1, 0.2, 0.4, 0.7, 1.0, 1.5, 2.0, 3.0, 5.0];
    let best_on = |a: f64, b: f64, step: f64, decays: &[f64]| -> (f64, f64) {
        let steps = ((b - a) / step).ceil() as usize;
        let mut best = (a, 0.0, f64::INFINITY);
        for i in 0..=steps {
            let f = (a + i as f64 * step).min(b);
            for &d in decays {
                let m = misfit(f, d);
                if m < best.2 {
                    best = (f, d, m);
                }
            }
        }
        (best.0, best.1)
    };
    let (coarse, _) = best_on(lo, hi, 0.05, &[0.0]);
    let (mid, decay) = best_on(
        (coarse - 0.5).max(lo),
        (coarse + 0.5).min(hi),
        0.01,
        &decays,
    );
    let fine: Vec<f64> = (0..=20).map(|i| decay * (0.8 + 0.02 * i as f64)).collect();
    Ok(best_on((mid - 0.01).max(lo), (mid + 0.01).min(hi), 0.0005, &fine).0)
}

/// `log` as the model sees it through the rig's `sensors`: the torque the hub received and
/// the strain the beam's curvature implies.
pub fn corrected(log: &Log, sensors: &Sensors) -> Log {
    let mut log = log.clone();
    log.torque
        .iter_mut()
        .for_each(|u| *u = sensors.applied_torque(*u));
    log.beam_signal
        .iter_mut()
        .for_each(|e| *e /= sensors.gauge_scale);
    log
}

/// The model against a log, sample by sample: what `beam replay --csv` writes and the
/// calibration figures draw. Model strains are as the log's gauge would read them.
#[derive(Clone, Debug, PartialEq)]
pub struct Traces {
    /// Time from the log's first sample, s.
    pub t: Vec<f64>,
    /// Logged hub angle, rad.
    pub theta_log: Vec<f64>,
    /// Hub angle of the torque replayed open loop through the sensors, rad.
    pub theta_model: Vec<f64>,
    /// Hub rate from the logged angle (the prescribed hub's), rad/s.
    pub omega_log: Vec<f64>,
    /// Hub rate of the torque replay (central differences), rad/s.
    pub omega_model: Vec<f64>,
    /// What the log measures the beam with.
    pub sensor: BeamSensor,
    /// The logged beam signal (root strain or tip deflection, SI).
    pub beam_log: Vec<f64>,
    /// The same of the beam on the prescribed hub.
    pub beam_model: Vec<f64>,
    /// Logged mid-span strain and the model's (hub prescribed), where the log has it.
    pub mid: Option<(Vec<f64>, Vec<f64>)>,
}

/// The model of `params` against the whole of `log`, read through `sensors`; `None` if the
/// model breaks down.
pub fn traces<const N: usize>(params: &BeamParams, sensors: &Sensors, log: &Log) -> Option<Traces> {
    let t: Vec<f64> = log.t.iter().map(|x| x - log.t[0]).collect();
    let t_end = t[t.len() - 1];
    let (th, _) = replay_torque::<N>(params, &corrected(log, sensors), t_end)?;
    let n = th.len().min(t.len());
    let hub = HubMotion::of(log, hub_window_s(params));
    let pr = prescribed::<N>(params, log, &hub)?;
    let dt = t[1] - t[0];
    let omega_model = (0..n)
        .map(|k| {
            let (a, b) = (k.saturating_sub(1), (k + 1).min(n - 1));
            if b > a {
                (th[b] - th[a]) / ((b - a) as f64 * dt)
            } else {
                0.0
            }
        })
        .collect();
    let g = sensors.gauge_scale;
    Some(Traces {
        t: t[..n].to_vec(),
        theta_log: log.theta[..n].to_vec(),
        theta_model: th,
        omega_log: hub.omega[..n].to_vec(),
        omega_model,
        sensor: log.sensor,
        beam_log: log.beam_signal[..n].to_vec(),
        beam_model: pr.beam_signal[..n].iter().map(|e| e * g).collect(),
        mid: log
            .mid_strain
            .as_ref()
            .map(|m| (m[..n].to_vec(), pr.mid_strain[..n].to_vec())),
    })
}

impl Traces {
    /// As CSV: `t_s, theta_log_rad, theta_model_rad, omega_log_rad_s, omega_model_rad_s,
    /// root_strain_log, root_strain_model[, mid_strain_log, mid_strain_model]` (for a tip
    /// sensor's log `tip_m_log, tip_m_model` in place of the root strain's).
    pub fn write_csv(&self, w: &mut dyn std::io::Write) -> std::io::Result<()> {
        let beam = match self.sensor {
            BeamSensor::RootStrain => "root_strain",
            BeamSensor::TipDeflection => "tip_m",
        };
        write!(
            w,
            "t_s,theta_log_rad,theta_model_rad,omega_log_rad_s,omega_model_rad_s,{beam}_log,{beam}_model"
        )?;
        if self.mid.is_some() {
            write!(w, ",mid_strain_log,mid_strain_model")?;
        }
        writeln!(w)?;
        for k in 0..self.t.len() {
            write!(
                w,
                "{},{},{},{},{},{},{}",
                self.t[k],
                self.theta_log[k],
                self.theta_model[k],
                self.omega_log[k],
                self.omega_model[k],
                self.beam_log[k],
                self.beam_model[k]
            )?;
            if let Some((l, m)) = &self.mid {
                write!(w, ",{},{}", l[k], m[k])?;
            }
            writeln!(w)?;
        }
        Ok(())
    }

    /// The paper's calibration figures: hub angle, hub rate, root strain and (where logged)
    /// mid-span strain, measured against the model, to `path` (.png or .svg).
    pub fn plot(
        &self,
        title: &str,
        path: &std::path::Path,
    ) -> Result<(), crate::io::plot::PlotError> {
        let pts = |v: &[f64], scale: f64| -> Vec<(f64, f64)> {
            self.t.iter().zip(v).map(|(t, y)| (*t, y * scale)).collect()
        };
        let deg = 180.0 / core::f64::consts::PI;
        let mut panels = vec![
            (
                "Hub angle (model: logged torque, open loop)",
                "deg",
                vec![
                    ("log", pts(&self.theta_log, deg)),
                    ("model", pts(&self.theta_model, deg)),
                ],
            ),
            (
                "Hub rate (log: quadratic fit to the angle; model: torque replay)",
                "deg/s",
                vec![
                    ("log", pts(&self.omega_log, deg)),
                    ("model", pts(&self.omega_model, deg)),
                ],
            ),
            (
                match self.sensor {
                    BeamSensor::RootStrain => "Root strain (model: logged hub angle)",
                    BeamSensor::TipDeflection => "Tip deflection (model: logged hub angle)",
                },
                match self.sensor {
                    BeamSensor::RootStrain => "microstrain",
                    BeamSensor::TipDeflection => "mm",
                },
                vec![
                    ("log", pts(&self.beam_log, self.sensor.display_scale())),
                    ("model", pts(&self.beam_model, self.sensor.display_scale())),
                ],
            ),
        ];
        if let Some((l, m)) = &self.mid {
            panels.push((
                "Mid-span strain (model: logged hub angle)",
                "microstrain",
                vec![("log", pts(l, 1e6)), ("model", pts(m, 1e6))],
            ));
        }
        crate::io::plot::plot_panels(title, panels, path)
    }
}

/// The model of `params`, read through the rig's `sensors`, against `log` over `windows`.
pub fn replay_report<const N: usize>(
    params: &BeamParams,
    sensors: &Sensors,
    log: &Log,
    windows: &Windows,
) -> Option<ReplayReport> {
    let t: Vec<f64> = log.t.iter().map(|x| x - log.t[0]).collect();
    let t_last = t[t.len() - 1];
    let (th, _) = replay_torque::<N>(params, &corrected(log, sensors), windows.settle_end_s)?;
    let eps: Vec<f64> = replay_prescribed::<N>(params, log)?
        .into_iter()
        .map(|e| e * sensors.gauge_scale)
        .collect();
    let in_window =
        |k: usize| t[k] >= windows.start_s - 1e-9 && t[k] <= windows.settle_end_s + 1e-9;
    // The search sees only modes above two cycles of the window; a window shorter than two
    // periods of the model's first clamped mode (the slowest the beam rings at after a move)
    // would report another frequency than the mode's (a 3.4 Hz mode in 0.4 s read 6.2-6.7 Hz).
    let first_hz = ModalModel::<N>::try_build(&model_core::Beam::try_build(*params).ok()?)
        .ok()?
        .clamped_hz[0];
    let short = t_last - windows.end_s < 2.0 / first_hz;
    let freq = |signal: &[f64]| {
        if short {
            Err(NoFrequency::WindowTooShort)
        } else {
            vibration_hz(&t, signal, windows.end_s, t_last)
        }
    };
    let (freq_log, freq_model) = (freq(&log.beam_signal), freq(&eps));
    let unit = log.sensor.display_scale();
    let (mut se, mut ss, mut sm, mut n) = (0.0, 0.0, 0.0, 0usize);
    for k in 0..th.len().min(eps.len()) {
        if in_window(k) {
            se += (th[k] - log.theta[k]).powi(2);
            ss += ((eps[k] - log.beam_signal[k]) * unit).powi(2);
            sm += (log.beam_signal[k] * unit).powi(2);
            n += 1;
        }
    }
    let n = n.max(1) as f64;
    let (strain_err, strain_rms) = ((ss / n).sqrt(), (sm / n).sqrt());
    Some(ReplayReport {
        hub_rms_err_deg: (se / n).sqrt().to_degrees(),
        beam_signal: log.sensor.name(),
        beam_unit: log.sensor.unit(),
        beam_rms_err: strain_err,
        beam_rms_measured: strain_rms,
        beam_rel_err: strain_err / strain_rms.max(1e-12),
        freq_log_hz: freq_log.ok(),
        freq_model_hz: freq_model.ok(),
        freq_note: match (freq_log, freq_model) {
            (Err(NoFrequency::WindowTooShort), _) | (_, Err(NoFrequency::WindowTooShort)) => {
                Some(format!(
                    "window too short: the {:.3} s after the move hold under two cycles of the vibration",
                    t_last - windows.end_s
                ))
            }
            (Err(NoFrequency::Flat), _) | (_, Err(NoFrequency::Flat)) => {
                Some("no vibration after the move".into())
            }
            _ => None,
        },
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A smooth slew of 0.3 rad over 1 s at 500 Hz, its angle quantised to `step` (if any).
    fn slew_log(step: Option<f64>) -> Log {
        let t: Vec<f64> = (0..750).map(|k| k as f64 * 0.002).collect();
        let theta = t
            .iter()
            .map(|&t| {
                let x = t.min(1.0);
                let th = 0.3
                    * (x - (2.0 * std::f64::consts::PI * x).sin() / (2.0 * std::f64::consts::PI));
                step.map_or(th, |q| q * (th / q).round())
            })
            .collect();
        Log {
            torque: vec![0.0; t.len()],
            beam_signal: vec![0.0; t.len()],
            sensor: BeamSensor::RootStrain,
            mid_strain: None,
            theta,
            t,
        }
    }

    #[test]
    fn a_gauges_lag_is_found_and_taken_back_out() {
        // The strain of a beam 10 % stiffer than the model, on the slew's hub, logged 40 ms
        // late (20 samples at 500 Hz).
        let model = BeamParams::aluminium();
        let truth = BeamParams {
            ei_nm2: model.ei_nm2 * 1.1,
            ..model
        };
        let mut log = slew_log(None);
        let strain = replay_prescribed::<3>(&truth, &log).unwrap();
        let lag = 20;
        log.beam_signal = (0..strain.len())
            .map(|k| strain[k.saturating_sub(lag)])
            .collect();
        // On the beam's own model, to within a millisecond; on the model a tenth off, this
        // slow 1 s slew's strain drifts in phase over the move and pulls the peak early
        // (by 7 ms here; `calibrate` finds it again on its result).
        let found = strain_delay::<3>(&truth, &log).unwrap();
        assert!((found - 0.040).abs() < 0.001, "{found}");
        let off = strain_delay::<3>(&model, &log).unwrap();
        eprintln!("lag found on the model a tenth off: {off}");
        assert!(off > 0.025 && off < found, "{off}");
        // Without a lag, none found (within a sample).
        let mut on_time = slew_log(None);
        on_time.beam_signal = strain.clone();
        assert!(strain_delay::<3>(&truth, &on_time).unwrap().abs() < 0.001);
        // Taken back out, the strain is the beam's again, the log shorter by the lag.
        let back = log.strain_advanced(lag as f64 * 0.002);
        assert_eq!(back.t.len(), log.t.len() - lag - 1);
        for (b, s) in back.beam_signal.iter().zip(&strain).skip(lag) {
            assert!((b - s).abs() <= 1e-12 * s.abs().max(1e-9), "{b} {s}");
        }
    }

    #[test]
    fn following_the_strain_puts_back_the_vibration_the_prescribed_hub_missed() {
        // The real hub chatters at 60 Hz for its first 0.1 s, which excites the beam; the
        // prescribed hub (the logged angle without the chatter) does not. After the chatter
        // the two hubs are the same, so what differs is the beam's state: open, the model
        // has none of that vibration; corrected by the logged strain, it has.
        let params = BeamParams::aluminium();
        let clean = slew_log(None);
        let mut chattering = clean.clone();
        for (th, t) in chattering.theta.iter_mut().zip(&clean.t) {
            if *t < 0.1 {
                *th += 2e-3 * (2.0 * std::f64::consts::PI * 60.0 * t).sin();
            }
        }
        let real_hub = HubMotion::of(&chattering, 0.004);
        let truth = prescribed::<3>(&params, &chattering, &real_hub).unwrap();
        let mut log = clean.clone();
        log.beam_signal = truth.beam_signal.clone();
        let hub = HubMotion::of(&clean, 0.004);
        let alpha_err = hub.alpha_rms_diff(&real_hub);
        let open = prescribed::<3>(&params, &log, &hub).unwrap();
        let observer = StrainObserver {
            gauge_scale: 1.0,
            alpha_err,
            strain_err: 1e-7,
        };
        let followed = prescribed_observed::<3>(&params, &log, &hub, Some(observer)).unwrap();
        // After the chatter and a settling time of the observer.
        let after: Vec<usize> = (0..clean.t.len()).filter(|&k| clean.t[k] > 0.2).collect();
        let rms = |a: &[f64], b: &[f64]| {
            (after.iter().map(|&k| (a[k] - b[k]).powi(2)).sum::<f64>() / after.len() as f64).sqrt()
        };
        let size = rms(&truth.flex_torque_nm, &vec![0.0; clean.t.len()]);
        let (e_open, e_followed) = (
            rms(&open.flex_torque_nm, &truth.flex_torque_nm),
            rms(&followed.flex_torque_nm, &truth.flex_torque_nm),
        );
        assert!(
            e_open > 0.05 * size,
            "the chatter left too little: {e_open} of {size}"
        );
        assert!(
            e_followed < 0.2 * e_open,
            "torque after the chatter: {e_followed} against {e_open} open (of {size})"
        );
    }

    #[test]
    fn the_encoder_step_is_found_on_a_quantised_angle_and_not_on_a_smooth_one() {
        let q = 2.0 * std::f64::consts::PI / 16384.0;
        let found = encoder_step(&slew_log(Some(q)).theta).unwrap();
        assert!((found / q - 1.0).abs() < 1e-9, "{found} against {q}");
        assert_eq!(encoder_step(&slew_log(None).theta), None);
        assert_eq!(encoder_step(&[0.0, q, 0.0]), None);
        // Logged in degrees to three decimals (as another rig's CSV might be), then read
        // back in radians: off the grid by up to 2.3 % of a step, and still found.
        let printed: Vec<f64> = slew_log(Some(q))
            .theta
            .iter()
            .map(|t| (t.to_degrees() * 1e3).round() / 1e3 * std::f64::consts::PI / 180.0)
            .collect();
        let found = encoder_step(&printed).unwrap();
        assert!((found / q - 1.0).abs() < 1e-3, "{found} against {q}");
    }

    #[test]
    fn requantising_keeps_the_step_moves_the_grid_and_stays_within_a_step() {
        let q = 2.0 * std::f64::consts::PI / 4096.0;
        let log = slew_log(Some(q));
        for phase in ENCODER_PHASES {
            let again = requantised(&log, 6, q, phase);
            // On the grid moved by the phase: (theta - origin) / q + phase is an integer.
            for (a, b) in again.theta.iter().zip(&log.theta) {
                let n = a / q + phase;
                assert!((n - n.round()).abs() < 1e-6, "{a} is off the moved grid");
                assert!((a - b).abs() <= 1.5 * q, "{a} is more than a step from {b}");
            }
            assert!(again.theta.iter().zip(&log.theta).any(|(a, b)| a != b));
        }
    }

    #[test]
    fn finds_the_frequency_of_a_noisy_damped_sinusoid_on_a_drifting_line() {
        // 2.7 Hz decaying at 0.5/s, on a drift, with noise a fifth of the initial amplitude
        // (a small residual read by a noisy gauge): the estimate must land within 1 %.
        let mut seed = 7u64;
        let mut noise = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed as f64 / u64::MAX as f64 - 0.5) * 2.0 * 0.2 * 3f64.sqrt() / 3.0
        };
        let t: Vec<f64> = (0..1000).map(|k| k as f64 * 0.002).collect();
        let y: Vec<f64> = t
            .iter()
            .map(|&t| {
                (-0.5 * t).exp() * (2.0 * core::f64::consts::PI * 2.7 * t + 0.3).cos()
                    + 0.4 * t
                    + noise()
            })
            .collect();
        let f = vibration_hz(&t, &y, 0.0, 2.0).unwrap();
        assert!((f - 2.7).abs() < 0.027, "{f}");
        // Flat or too short: no frequency.
        assert_eq!(
            vibration_hz(&t, &vec![1.0; 1000], 0.0, 2.0),
            Err(NoFrequency::Flat)
        );
        assert_eq!(vibration_hz(&t, &y, 0.0, 0.02), Err(NoFrequency::Flat));
    }

    #[test]
    fn a_window_under_two_cycles_of_the_first_mode_is_too_short_not_another_frequency() {
        // The aluminium beam (first clamped mode 5.48 Hz, two periods 0.365 s) after a PD
        // slew: cut 0.25 s after the move's end the window holds under two of its periods,
        // and the replay says so rather than reading another frequency; 1.2 s after it, both
        // frequencies are read and agree.
        use crate::identify::calibrate::{find_windows, read_log};
        let truth = BeamParams::aluminium();
        let m = ModalModel::<3>::try_build(&model_core::Beam::try_build(truth).unwrap()).unwrap();
        let run = beam_sim::sim::simulate(
            &m,
            model_core::Law::Pd(model_core::PdGains::BASELINE),
            &beam_sim::sim::SimOptions {
                duration_s: 2.0,
                ..Default::default()
            },
        )
        .unwrap();
        let mut csv = Vec::new();
        crate::io::files::write_trace_csv(&run, &mut csv).unwrap();
        let log = read_log(std::str::from_utf8(&csv).unwrap(), "log.csv").unwrap();
        let w = find_windows(&log).unwrap();
        let upto = |s: f64| log.between(None, Some(w.end_s + s)).unwrap();
        let short = replay_report::<3>(&truth, &Sensors::default(), &upto(0.25), &w).unwrap();
        assert_eq!((short.freq_log_hz, short.freq_model_hz), (None, None));
        assert!(short.freq_note.unwrap().starts_with("window too short"));
        let long = replay_report::<3>(&truth, &Sensors::default(), &upto(1.2), &w).unwrap();
        let (fl, fm) = (long.freq_log_hz.unwrap(), long.freq_model_hz.unwrap());
        assert!((fl - fm).abs() / fl < 0.03, "{fl} vs {fm} Hz");
    }
}
