//! The model against a log (`beam replay`): the beam driven by the logged hub angle (the hub
//! prescribed, so torque and motor errors cannot leak into the flexible part) and, for the
//! hub itself, by the logged torque open loop; with the figures that say how well the model
//! explains the log.

use crate::calibrate::{replay as replay_torque, Log, Windows};
use host_tests::plant::Plant;
use model_core::{Beam, BeamParams, ModalModel};
use serde::Serialize;

/// How well a model explains a log.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ReplayReport {
    /// RMS hub-angle error of the open-loop torque replay over the move and settling, deg.
    pub hub_rms_err_deg: f64,
    /// RMS root-strain error with the hub prescribed, over the move and settling, ue.
    pub strain_rms_err_ue: f64,
    /// RMS of the measured root strain over the same window, ue (the error's yardstick).
    pub strain_rms_measured_ue: f64,
    /// The strain error as a fraction of the measured RMS.
    pub strain_rel_err: f64,
    /// The first vibration frequency in the logged strain from the end of the move to the
    /// end of the log, Hz.
    pub freq_log_hz: Option<f64>,
    /// The same from the model's strain (hub prescribed), Hz.
    pub freq_model_hz: Option<f64>,
}

/// Hub rate and acceleration at each sample, from a local quadratic fit to the logged angle
/// over `half` samples either side (a Savitzky-Golay differentiator: the encoder's steps
/// would make plain differences useless for the acceleration).
pub fn hub_rates(log: &Log, half: usize) -> (Vec<f64>, Vec<f64>) {
    let n = log.t.len();
    let dt = log.t[1] - log.t[0];
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
        omega[k] = b / dt;
        alpha[k] = 2.0 * c / (dt * dt);
    }
    (omega, alpha)
}

/// The root strain of the beam driven by the logged hub motion, at each sample, with an
/// `N`-mode model of `params`; `None` if the parameters are invalid or the model breaks
/// down. RK4, four steps a sample, with the hub's rate and acceleration held over each.
pub fn replay_prescribed<const N: usize>(params: &BeamParams, log: &Log) -> Option<Vec<f64>> {
    let model = ModalModel::<N>::try_build(&Beam::try_build(*params).ok()?).ok()?;
    let plant = Plant::new(model);
    let dt = log.t[1] - log.t[0];
    let half = ((0.005 / dt).round() as usize).max(2);
    let (omega, alpha) = hub_rates(log, half);
    let (mut q, mut qd) = ([0.0f64; N], [0.0f64; N]);
    let mut eps = Vec::with_capacity(log.t.len());
    let h = dt / 4.0;
    for k in 0..log.t.len() {
        eps.push(model_core::linalg::dot(&plant.model.root_strain_coef, &q));
        let (w, a) = (omega[k], alpha[k]);
        for _ in 0..4 {
            let f = |q: &[f64; N], qd: &[f64; N]| plant.flex_acceleration(q, qd, w, a);
            let add = |x: &[f64; N], d: &[f64; N], s: f64| -> [f64; N] {
                core::array::from_fn(|i| x[i] + s * d[i])
            };
            let (k1q, k1v) = (qd, f(&q, &qd));
            let (q2, v2) = (add(&q, &k1q, h / 2.0), add(&qd, &k1v, h / 2.0));
            let (k2q, k2v) = (v2, f(&q2, &v2));
            let (q3, v3) = (add(&q, &k2q, h / 2.0), add(&qd, &k2v, h / 2.0));
            let (k3q, k3v) = (v3, f(&q3, &v3));
            let (q4, v4) = (add(&q, &k3q, h), add(&qd, &k3v, h));
            let (k4q, k4v) = (v4, f(&q4, &v4));
            q = core::array::from_fn(|i| {
                q[i] + h / 6.0 * (k1q[i] + 2.0 * k2q[i] + 2.0 * k3q[i] + k4q[i])
            });
            qd = core::array::from_fn(|i| {
                qd[i] + h / 6.0 * (k1v[i] + 2.0 * k2v[i] + 2.0 * k3v[i] + k4v[i])
            });
        }
        if !q.iter().chain(qd.iter()).all(|x| x.is_finite()) {
            return None;
        }
    }
    Some(eps)
}

/// The dominant vibration frequency of `signal` over `[from, to]` s (times `t`), from its
/// crossings of its own mean; `None` with fewer than three crossings.
pub fn vibration_hz(t: &[f64], signal: &[f64], from: f64, to: f64) -> Option<f64> {
    let idx: Vec<usize> = (0..t.len())
        .filter(|&k| t[k] >= from && t[k] <= to)
        .collect();
    if idx.len() < 8 {
        return None;
    }
    let mean = idx.iter().map(|&k| signal[k]).sum::<f64>() / idx.len() as f64;
    let mut crossings = vec![];
    for w in idx.windows(2) {
        let (a, b) = (signal[w[0]] - mean, signal[w[1]] - mean);
        if a == 0.0 || (a < 0.0) != (b < 0.0) && b != 0.0 {
            // Linear interpolation of the crossing time.
            let f = if (b - a).abs() > 0.0 {
                -a / (b - a)
            } else {
                0.0
            };
            crossings.push(t[w[0]] + f * (t[w[1]] - t[w[0]]));
        }
    }
    if crossings.len() < 3 {
        return None;
    }
    let span = crossings[crossings.len() - 1] - crossings[0];
    (span > 0.0).then(|| (crossings.len() - 1) as f64 / (2.0 * span))
}

/// The model of `params` against `log` over `windows`.
pub fn replay_report<const N: usize>(
    params: &BeamParams,
    log: &Log,
    windows: &Windows,
) -> Option<ReplayReport> {
    let t: Vec<f64> = log.t.iter().map(|x| x - log.t[0]).collect();
    let t_last = t[t.len() - 1];
    let (th, _) = replay_torque::<N>(params, log, windows.settle_end_s)?;
    let eps = replay_prescribed::<N>(params, log)?;
    let in_window =
        |k: usize| t[k] >= windows.start_s - 1e-9 && t[k] <= windows.settle_end_s + 1e-9;
    let (mut se, mut ss, mut sm, mut n) = (0.0, 0.0, 0.0, 0usize);
    for k in 0..th.len().min(eps.len()) {
        if in_window(k) {
            se += (th[k] - log.theta[k]).powi(2);
            ss += ((eps[k] - log.root_strain[k]) * 1e6).powi(2);
            sm += (log.root_strain[k] * 1e6).powi(2);
            n += 1;
        }
    }
    let n = n.max(1) as f64;
    let (strain_err, strain_rms) = ((ss / n).sqrt(), (sm / n).sqrt());
    Some(ReplayReport {
        hub_rms_err_deg: (se / n).sqrt().to_degrees(),
        strain_rms_err_ue: strain_err,
        strain_rms_measured_ue: strain_rms,
        strain_rel_err: strain_err / strain_rms.max(1e-12),
        freq_log_hz: vibration_hz(&t, &log.root_strain, windows.end_s, t_last),
        freq_model_hz: vibration_hz(&t, &eps, windows.end_s, t_last),
    })
}
