//! The hub's motion from a log: its rates by local quadratic fits, the encoder's step found
//! from the angles, a log re-quantised at another phase of it, and the fit's width.

use crate::identify::calibrate::Log;
use model_core::BeamParams;

/// Hub rate and acceleration at each sample, from a local quadratic fit to the logged angle
/// over `half` samples either side (a Savitzky-Golay differentiator: the encoder's steps
/// would make plain differences useless for the acceleration).
pub fn hub_rates(log: &Log, half: usize) -> (Vec<f64>, Vec<f64>) {
    let (_, omega, alpha) = hub_fit(log, half);
    (omega, alpha)
}

/// The local quadratic fit of [`hub_rates`]: angle (smoothed), rate and acceleration.
pub(super) fn hub_fit(log: &Log, half: usize) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
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
