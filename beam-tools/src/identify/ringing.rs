//! The beam's ringing after a move, from the log alone, and the model's on the same hub:
//! the frequency and damping of the damped sinusoid (plus a line for the sensor's offset and
//! drift) that fits each best, with their intervals. Calibration holds its model to the log's
//! ringing, so that nothing the model is free to fit (a sensor's lag above all) can buy a
//! closer fit by moving the beam's frequency away from what the log rings at.
//!
//! The model rings on the logged hub (prescribed, as in `beam replay`): the two ring alike
//! only if the model's beam has the log's frequency. Where the hub swings with the beam (a
//! soft PD hold), the prescribed hub pulls the model's ring toward the log's, so the check is
//! weaker than the frequency error it guards against (a mode 43 % high rang 4 % high on
//! such a hub): it compares the two with the intervals of both, and a tolerance of
//! [`RING_TOLERANCE`].

use super::calibrate::{Experiment, Log, Windows};
use model_core::{Beam, BeamParams, ModalModel};
use serde::Serialize;

/// What the log rings at, found from it alone.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Ringing {
    /// The frequency it rings at, Hz (undamped: the damped one over `sqrt(1 - zeta^2)`).
    pub hz: f64,
    /// Its one-sigma error, Hz (from the fit's curvature, with the residuals' correlation
    /// counted).
    pub hz_sigma: f64,
    /// The damping ratio it decays with.
    pub damping_ratio: f64,
    /// Its one-sigma error.
    pub damping_sigma: f64,
    /// The window fitted, s from the log's first sample.
    pub from_s: f64,
    /// Its end.
    pub to_s: f64,
}

/// Why a log gives no ringing.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub enum NoRinging {
    /// The window after the move holds under two cycles of the slowest frequency it could
    /// show, or under 32 samples.
    TooShort,
    /// The signal does not ring in it (nothing beyond the line, or no minimum).
    Flat,
}

/// The windows `[from, to]` s (from the log's first sample) a log's ringing is fitted
/// over, in the order they are tried, both to the end of the log (or of its cut: the next
/// move's rest). First from where the hub stays within two of the encoder's steps (or
/// 0.1 % of the move) of its final angle: a hub that friction stopped leaves the beam
/// ringing clamped, lightly damped, while before it the hub swung with the beam and the two
/// rang together, more damped, so that one sinusoid fits neither. Then, where that leaves
/// too little to ring in (a soft hold swings the hub to the end), from where the hub has
/// come within a tenth of the move of its final angle.
pub fn ring_windows(log: &Log, windows: &Windows) -> [(f64, f64); 2] {
    let t0 = log.t[0];
    let n = log.t.len();
    let tail = (n / 20).max(1);
    let last = log.theta[n - tail..].iter().sum::<f64>() / tail as f64;
    let start = (0..n)
        .position(|k| log.t[k] - t0 >= windows.start_s)
        .unwrap_or(0);
    let travel = (last - log.theta[start]).abs();
    let end = log.t[n - 1] - t0;
    let near = (start..n)
        .find(|&k| (log.theta[k] - last).abs() <= 0.1 * travel)
        .map_or(windows.end_s, |k| log.t[k] - t0);
    let band = super::hub::encoder_step(&log.theta)
        .map_or(0.0, |q| 2.0 * q)
        .max(1e-3 * travel);
    let still = (start..n)
        .rev()
        .find(|&k| (log.theta[k] - last).abs() > band)
        .map_or(near, |k| (log.t[k] - t0).max(near));
    [(still, end), (near, end)]
}

/// The log's ringing over the first of [`ring_windows`] it rings in, with that window.
fn ring_of(t: &[f64], signal: &[f64], windows: &[(f64, f64); 2]) -> Result<Ringing, NoRinging> {
    ringing(t, signal, windows[0].0, windows[0].1)
        .or_else(|_| ringing(t, signal, windows[1].0, windows[1].1))
}

/// The damped sinusoid plus line that explains `signal` best over `[from, to]` s (times `t`,
/// uniformly sampled). The search runs over frequencies from two cycles of the window to a
/// quarter of the sample rate (at most 200 Hz), on a 1 % grid; its deepest minima are
/// refined (frequency and damping together), those that ring (damping under 0.45) kept, and
/// the slowest of them that explains at least half what the best does is taken: the first
/// mode, where a fast move also rang a second one.
pub fn ringing(t: &[f64], signal: &[f64], from: f64, to: f64) -> Result<Ringing, NoRinging> {
    let idx: Vec<usize> = (0..t.len().min(signal.len()))
        .filter(|&k| t[k] >= from - 1e-9 && t[k] <= to + 1e-9)
        .collect();
    if idx.len() < 32 {
        return Err(NoRinging::TooShort);
    }
    let w = Window {
        t: idx.iter().map(|&k| t[k] - t[idx[0]]).collect(),
        y: idx.iter().map(|&k| signal[k]).collect(),
    };
    if !w.y.iter().all(|v| v.is_finite()) {
        return Err(NoRinging::Flat);
    }
    let span = w.t[w.t.len() - 1];
    let dt = span / (w.t.len() - 1) as f64;
    let (lo, hi) = (2.0 / span, (0.25 / dt).min(200.0));
    if !(hi > lo) {
        return Err(NoRinging::TooShort);
    }
    let line_rss = w.line_rss().ok_or(NoRinging::Flat)?;
    // The coarse scan, at a light damping.
    let grid: Vec<f64> = (0..)
        .map(|i| lo * 1.01f64.powi(i))
        .take_while(|f| *f <= hi)
        .collect();
    let scan: Vec<f64> = grid.iter().map(|&f| w.rss(f, 0.02)).collect();
    let best = scan.iter().copied().fold(f64::INFINITY, f64::min);
    if !(best < 0.98 * line_rss) {
        return Err(NoRinging::Flat);
    }
    let minimum = |i: usize| {
        (i == 0 || scan[i] <= scan[i - 1]) && (i + 1 == scan.len() || scan[i] <= scan[i + 1])
    };
    // The deepest minima, refined; those that ring (a minimum that refines to a heavy
    // damping is the hub's slow motion, not the beam's, and may be the deepest); of them,
    // the slowest that explains half what the best ringing one does.
    let mut minima: Vec<usize> = (0..scan.len()).filter(|&i| minimum(i)).collect();
    minima.sort_by(|&a, &b| scan[a].total_cmp(&scan[b]));
    // (Each with its interval: a point whose misfit does not curve up both ways is not a
    // minimum of it.)
    let mut rings: Vec<(f64, f64, f64, (f64, f64))> = minima
        .into_iter()
        .take(RING_CANDIDATES)
        .map(|i| w.refine(grid[i]))
        .filter(|&(f, zeta)| zeta < MAX_RING_DAMPING && f > lo * 1.001 && f < hi * 0.999)
        .map(|(f, zeta)| (f, zeta, w.rss(f, zeta), w.sigmas(f, zeta)))
        .filter(|r| r.3 .0.is_finite())
        .collect();
    let best_ring = rings.iter().map(|r| r.2).fold(f64::INFINITY, f64::min);
    rings.sort_by(|a, b| a.0.total_cmp(&b.0));
    let (f, zeta, _, (sigma_f, sigma_z)) = rings
        .into_iter()
        .find(|r| line_rss - r.2 >= 0.5 * (line_rss - best_ring))
        .ok_or(NoRinging::Flat)?;
    Ok(Ringing {
        hz: f,
        hz_sigma: sigma_f,
        damping_ratio: zeta,
        damping_sigma: sigma_z,
        from_s: t[idx[0]],
        to_s: t[idx[idx.len() - 1]],
    })
}

/// How far apart a log's ringing and the model's may be, as a fraction of the log's
/// frequency, before they are said to disagree (whatever their intervals): what the hub's
/// smoothing and the model's modes cut off leave between them on a model that is right.
pub const RING_TOLERANCE: f64 = 0.005;

/// One log's ringing after its move against the model's on the same hub.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct LogRinging {
    /// What the log rings at, if it shows it.
    pub log: Option<Ringing>,
    /// What the model rings at, driven by the logged hub, over the same window.
    pub model: Option<Ringing>,
    /// Why one of them is missing, if one is.
    pub why_none: Option<NoRinging>,
    /// The model's first clamped mode on this log's beam (its tip mass), Hz.
    pub model_clamped_hz: f64,
}

impl LogRinging {
    /// The model's ringing off the log's, as a fraction of the log's.
    pub fn off(&self) -> Option<f64> {
        Some(self.model?.hz / self.log?.hz - 1.0)
    }

    /// How many of their combined one-sigma errors the two are apart.
    pub fn sigmas(&self) -> Option<f64> {
        let (l, m) = (self.log?, self.model?);
        Some((m.hz - l.hz).abs() / l.hz_sigma.hypot(m.hz_sigma))
    }

    /// Whether the model rings where the log does: within three combined errors or
    /// [`RING_TOLERANCE`]; `None` if either does not ring.
    pub fn agrees(&self) -> Option<bool> {
        Some(self.sigmas()? <= 3.0 || self.off()?.abs() <= RING_TOLERANCE)
    }
}

/// Each experiment's ringing after its move against `params`' on the same hub (an `N`-mode
/// model on the experiment's own tip mass, its beam driven by the logged hub).
pub fn check<const N: usize>(params: &BeamParams, exps: &[Experiment]) -> Vec<LogRinging> {
    exps.iter()
        .map(|e| {
            let p = e.params(params);
            let t: Vec<f64> = e.log.t.iter().map(|x| x - e.log.t[0]).collect();
            let log = ring_of(&t, &e.log.beam_signal, &ring_windows(&e.log, &e.windows));
            // The model over the window the log rang in.
            let model = log.and_then(|l| {
                super::prescribed::replay_prescribed::<N>(&p, &e.log)
                    .ok_or(NoRinging::Flat)
                    .and_then(|m| ringing(&t, &m, l.from_s, l.to_s))
            });
            let clamped = Beam::try_build(p)
                .ok()
                .and_then(|b| ModalModel::<N>::try_build(&b).ok())
                .map_or(f64::NAN, |m| m.clamped_hz[0]);
            LogRinging {
                log: log.ok(),
                model: model.ok(),
                why_none: log.err().or(model.err()),
                model_clamped_hz: clamped,
            }
        })
        .collect()
}

/// The worst disagreement of `checks` in combined errors (0 where every log agrees or none
/// rings): what a refit is judged by.
pub fn worst_sigmas(checks: &[LogRinging]) -> f64 {
    checks
        .iter()
        .filter(|c| c.agrees() == Some(false))
        .filter_map(LogRinging::sigmas)
        .fold(0.0, f64::max)
}

/// Where the logs of `checks` ring together, Hz: their frequencies weighted by their
/// errors; `None` if none rings.
pub fn ring_mean(checks: &[LogRinging]) -> Option<f64> {
    let (sum, weight) = checks
        .iter()
        .filter_map(|c| c.log)
        .map(|r| (r.hz, r.hz_sigma.max(1e-3 * r.hz).powi(-2)))
        .fold((0.0, 0.0), |(s, w), (hz, wt)| (s + hz * wt, w + wt));
    (weight > 0.0).then(|| sum / weight)
}

/// How many of the scan's deepest minima are refined and weighed as the ringing.
const RING_CANDIDATES: usize = 6;

/// The heaviest damping a refined minimum may have and be taken for a ringing: below the
/// damping search's bound (0.5), which a minimum that is the hub's slow drift runs into. A
/// PD-held hub's beam rings at up to 0.3 (the aluminium beam after the paper's slew under
/// PD 20/1: 4.37 Hz at 0.30).
const MAX_RING_DAMPING: f64 = 0.45;

/// The samples fitted, time from the window's start.
struct Window {
    t: Vec<f64>,
    y: Vec<f64>,
}

impl Window {
    /// Frequency and damping refined from `f`: each in turn by golden sections, until they
    /// stop moving.
    fn refine(&self, mut f: f64) -> (f64, f64) {
        let mut zeta = 0.02;
        for _ in 0..6 {
            let f_before = f;
            f = golden(|x| self.rss(x, zeta), f / 1.02, f * 1.02);
            zeta = golden(|z| self.rss(f, z), 0.0, 0.5);
            if (f - f_before).abs() < 1e-7 * f {
                break;
            }
        }
        (f, zeta)
    }

    /// The columns at `(f, zeta)`: the damped sinusoid's two and the line's two.
    fn columns(&self, f: f64, zeta: f64) -> Vec<[f64; 4]> {
        let w = core::f64::consts::TAU * f;
        let zeta = zeta.clamp(0.0, 0.95);
        let (sigma, wd) = (zeta * w, w * (1.0 - zeta * zeta).sqrt());
        self.t
            .iter()
            .map(|&t| {
                let e = (-sigma * t).exp();
                [e * (wd * t).cos(), e * (wd * t).sin(), 1.0, t]
            })
            .collect()
    }

    /// The one-sigma errors of frequency and damping at the minimum `(f, zeta)`, from the
    /// curvature of the misfit (the linear parts profiled out): the covariance is
    /// `2 s^2 H^-1`, with the residual variance counted over the independent samples the
    /// residuals' lag-one correlation leaves. Infinite where the misfit does not curve up.
    fn sigmas(&self, f: f64, zeta: f64) -> (f64, f64) {
        let rss = self.rss(f, zeta);
        let count = self.t.len() as f64;
        let rho = self.lag_one(f, zeta).clamp(0.0, 0.99);
        let s2 = rss / (count - 6.0).max(1.0) * (1.0 + rho) / (1.0 - rho);
        let (hf, hz) = (1e-4 * f, 1e-3_f64.max(0.05 * zeta));
        let zc = zeta.max(hz);
        let e = |df: f64, dz: f64| self.rss(f + df, zc + dz);
        let h00 = (e(hf, 0.0) - 2.0 * e(0.0, 0.0) + e(-hf, 0.0)) / (hf * hf);
        let h11 = (e(0.0, hz) - 2.0 * e(0.0, 0.0) + e(0.0, -hz)) / (hz * hz);
        let h01 = (e(hf, hz) - e(hf, -hz) - e(-hf, hz) + e(-hf, -hz)) / (4.0 * hf * hz);
        let det = h00 * h11 - h01 * h01;
        if det > 0.0 && h00 > 0.0 {
            ((2.0 * s2 * h11 / det).sqrt(), (2.0 * s2 * h00 / det).sqrt())
        } else {
            (f64::INFINITY, f64::INFINITY)
        }
    }

    /// The least-squares fit at `(f, zeta)`: its coefficients and residual sum of squares.
    fn fit(&self, f: f64, zeta: f64) -> Option<(Vec<f64>, Vec<[f64; 4]>, f64)> {
        let rows = self.columns(f, zeta);
        let mut normal = super::lsq::Normal::new(4);
        rows.iter()
            .zip(&self.y)
            .for_each(|(r, y)| normal.add(r, *y));
        let fit = normal.solve()?;
        Some((fit.coef, rows, fit.rss))
    }

    fn rss(&self, f: f64, zeta: f64) -> f64 {
        self.fit(f, zeta)
            .map_or(f64::INFINITY, |(_, _, rss)| rss.max(0.0))
    }

    /// The residual sum of squares of the line alone.
    fn line_rss(&self) -> Option<f64> {
        let mut line = super::lsq::Normal::new(2);
        self.t
            .iter()
            .zip(&self.y)
            .for_each(|(t, y)| line.add(&[1.0, *t], *y));
        line.solve().map(|f| f.rss).filter(|rss| *rss > 0.0)
    }

    /// The lag-one correlation of the residuals at `(f, zeta)`.
    fn lag_one(&self, f: f64, zeta: f64) -> f64 {
        let Some((coef, rows, _)) = self.fit(f, zeta) else {
            return 0.0;
        };
        let r: Vec<f64> = rows
            .iter()
            .zip(&self.y)
            .map(|(row, y)| y - row.iter().zip(&coef).map(|(a, b)| a * b).sum::<f64>())
            .collect();
        let var: f64 = r.iter().map(|x| x * x).sum();
        if var <= 0.0 {
            return 0.0;
        }
        r.windows(2).map(|p| p[0] * p[1]).sum::<f64>() / var
    }
}

/// The minimum of `g` on `[a, b]` by golden sections (to a millionth of the interval).
fn golden(g: impl Fn(f64) -> f64, mut a: f64, mut b: f64) -> f64 {
    let r = 0.5 * (5f64.sqrt() - 1.0);
    let (mut c, mut d) = (b - r * (b - a), a + r * (b - a));
    let (mut gc, mut gd) = (g(c), g(d));
    let tol = 1e-6 * (b - a);
    while b - a > tol {
        if gc <= gd {
            b = d;
            (d, gd) = (c, gc);
            c = b - r * (b - a);
            gc = g(c);
        } else {
            a = c;
            (c, gc) = (d, gd);
            d = a + r * (b - a);
            gd = g(d);
        }
    }
    0.5 * (a + b)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A damped sinusoid of `f` Hz and `zeta` on an offset and a drift, sampled at `dt`.
    fn ring(f: f64, zeta: f64, dt: f64, n: usize) -> (Vec<f64>, Vec<f64>) {
        let w = core::f64::consts::TAU * f;
        let t: Vec<f64> = (0..n).map(|k| k as f64 * dt).collect();
        let y = t
            .iter()
            .map(|&t| {
                3.0 + 0.2 * t
                    + (-zeta * w * t).exp() * (w * (1.0 - zeta * zeta).sqrt() * t + 0.4).cos()
            })
            .collect();
        (t, y)
    }

    #[test]
    fn a_damped_ring_is_found_at_its_frequency_and_damping() {
        let (t, y) = ring(1.7, 0.03, 1e-3, 4000);
        let r = ringing(&t, &y, 0.0, 4.0).unwrap();
        assert!((r.hz / 1.7 - 1.0).abs() < 1e-4, "{r:?}");
        assert!((r.damping_ratio - 0.03).abs() < 1e-4, "{r:?}");
        // A second, faster and smaller mode does not take its place.
        let (_, fast) = ring(10.6, 0.01, 1e-3, 4000);
        let both: Vec<f64> = y.iter().zip(&fast).map(|(a, b)| a + 0.3 * b).collect();
        let r = ringing(&t, &both, 0.0, 4.0).unwrap();
        assert!((r.hz / 1.7 - 1.0).abs() < 2e-3, "{r:?}");
    }

    #[test]
    fn rounding_widens_the_interval_and_it_covers_the_truth() {
        let (t, clean) = ring(1.6, 0.02, 1e-3, 5000);
        // Rounded to a thirtieth of its swing, as a 1 mm tip sensor reads a 30 mm swing.
        let y: Vec<f64> = clean.iter().map(|y| (y * 30.0).round() / 30.0).collect();
        let r = ringing(&t, &y, 0.0, 5.0).unwrap();
        assert!((r.hz - 1.6).abs() < 3.0 * r.hz_sigma, "{r:?}");
        assert!(r.hz_sigma > 0.0 && r.hz_sigma < 0.01, "{r:?}");
        assert!(
            (r.damping_ratio - 0.02).abs() < 3.0 * r.damping_sigma,
            "{r:?}"
        );
    }

    #[test]
    fn too_short_or_flat_gives_no_ringing() {
        let t: Vec<f64> = (0..1000).map(|k| k as f64 * 1e-3).collect();
        let line: Vec<f64> = t.iter().map(|t| 1.0 + 2.0 * t).collect();
        assert_eq!(ringing(&t, &line, 0.0, 1.0), Err(NoRinging::Flat));
        assert_eq!(ringing(&t, &line, 0.0, 0.02), Err(NoRinging::TooShort));
    }
}
