//! The drive's sampled loop about rest, for checking a design on a plant it was not made
//! for (more modes, a beam off the model): the plant sampled on all its modes, the observer
//! as the drive's tick runs it, the regulator, and the feedback's low-pass. Linear: the
//! centrifugal terms are zero at rest, the encoder is read as a point (as while the
//! reference moves; at rest the drive reads it as its count's interval, which only ever
//! corrects less), the identifier's stiffness is a given factor on the model's, and a
//! sliding-mode law is inside its boundary layer, where its switching term is a gain on
//! the regulator's output.

use super::dense::mul;
use super::{mass_inverse, sampled_with, LqgDesign, DESIGN_MODES, MAX_STATES};
use crate::modal::{ModalModel, MAX_MODES};

/// How the drive runs a design in the loop [`loop_radius`] looks at.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LoopSetting {
    /// The moving regulator's weight: 0 at rest, 1 while the reference moves (the gain is
    /// `k + w k_move`, [`LqgDesign::k_move`]).
    pub move_weight: f64,
    /// The factor on the regulator's output: 1 for the LQG law, `1 + Jeff A beta / K_rate`
    /// for the full-state sliding mode inside its boundary layer.
    pub gain: f64,
    /// The feedback low-pass's step, in (0, 1]: each tick the torque moves this share of the
    /// way from last tick's to the new command (1: the command as it is).
    pub lowpass: f64,
    /// Whether the hub angle's integral is in the loop ([`LqgDesign::ki`]; the LQG law at
    /// rest).
    pub integral: bool,
    /// The factor on the modes' restoring force in the observer's prediction: 1 as
    /// designed, the beam's stiffness against the model's once a drive that identifies has
    /// found it (its tick scales the modes' coordinates in the rates' rows by it).
    pub stiffness: f64,
}

/// Index of the hub rate in a design's layout.
const RATE: usize = 1 + DESIGN_MODES;

/// States of the loop at most: the plant's, the observer's, the low-pass's and the integral.
const L: usize = 2 + 2 * MAX_MODES + MAX_STATES + 2;

/// The spectral radius of the sampled closed loop of `design` run as `setting` says on
/// `plant` (any number of modes), at a tick of `ts_s`: below 1 the loop is stable, and
/// `ln(radius) / ts_s` is its slowest pole's real part, 1/s. Each tick, as the drive's:
/// the readings of the plant's hub angle and root strain; the observer's prediction from
/// last tick's estimate and torque, and its update; the regulator's command on the estimate
/// and the low-pass's state; the low-pass; the torque held over the tick. `None` if the
/// plant cannot be sampled.
pub fn loop_radius<const N: usize>(
    plant: &ModalModel<N>,
    design: &LqgDesign,
    setting: LoopSetting,
    ts_s: f64,
) -> Option<f64> {
    let minv = mass_inverse(plant)?;
    let (ap, bp) = sampled_with(plant, &minv, ts_s)?;
    let np = 2 + 2 * N;
    let (xh, fi, zi) = (np, np + MAX_STATES, np + MAX_STATES + 1);
    let n = zi + 1;
    let d = design;
    let w = setting.move_weight;
    let a = setting.lowpass;
    // One tick of the loop from `z`: the loop is linear, so its matrix is the tick applied
    // to each unit vector.
    let tick = |z: &[f64; L]| -> [f64; L] {
        let f = z[fi];
        let theta = z[0];
        let strain: f64 = (0..N).map(|i| plant.root_strain_coef[i] * z[1 + i]).sum();
        let pred: [f64; MAX_STATES] = core::array::from_fn(|i| {
            let own = if i == 0 { z[xh] } else { 0.0 };
            let stiff = |j: usize| {
                if i >= RATE && j < RATE {
                    setting.stiffness
                } else {
                    1.0
                }
            };
            own + d.bd[i] as f64 * f
                + (1..MAX_STATES)
                    .map(|j| stiff(j) * d.ad[i][j - 1] as f64 * z[xh + j])
                    .sum::<f64>()
        });
        let innov = [
            theta - pred[0],
            strain - d.strain_coef[0] as f64 * pred[1] - d.strain_coef[1] as f64 * pred[2],
        ];
        let est: [f64; MAX_STATES] = core::array::from_fn(|i| {
            pred[i] + d.l[i][0] as f64 * innov[0] + d.l[i][1] as f64 * innov[1]
        });
        let integral = if setting.integral {
            z[zi] + ts_s * est[0]
        } else {
            0.0
        };
        let regulator = (d.k_filter as f64 + w * d.k_move_filter as f64) * f
            + (0..MAX_STATES)
                .map(|i| (d.k[i] as f64 + w * d.k_move[i] as f64) * est[i])
                .sum::<f64>();
        let feedback = setting.gain * regulator + d.ki as f64 * integral;
        let u = (1.0 - a) * f - a * feedback;
        let mut out = [0.0; L];
        for i in 0..np {
            out[i] = bp[i] * u + (0..np).map(|j| ap[i][j] * z[j]).sum::<f64>();
        }
        out[xh..xh + MAX_STATES].copy_from_slice(&est);
        out[fi] = u;
        out[zi] = integral;
        out
    };
    let mut m = [[0.0; L]; L];
    for j in 0..n {
        let mut unit = [0.0; L];
        unit[j] = 1.0;
        let col = tick(&unit);
        for i in 0..n {
            m[i][j] = col[i];
        }
    }
    Some(spectral_radius(&m, n))
}

/// The spectral radius of the leading `n` by `n` block of `m`, from the growth of its powers
/// (Gelfand's formula, `||M^k||^(1/k) -> rho(M)`): `M^(2^24)` by squaring, renormalised
/// each time, so that the estimate is within a few parts in a million of the radius.
pub(super) fn spectral_radius<const S: usize>(m: &[[f64; S]; S], n: usize) -> f64 {
    const SQUARINGS: i32 = 24;
    let mut p = *m;
    let mut log_scale = 0.0f64;
    for _ in 0..SQUARINGS {
        let sq = mul(&p, &p, n);
        let big = sq.iter().flatten().fold(0.0f64, |b, v| b.max(v.abs()));
        if !(big > 0.0 && big.is_finite()) {
            // Nilpotent (or overflowed, which renormalising each time rules out).
            return 0.0;
        }
        log_scale = 2.0 * log_scale + libm::log(big);
        p = sq.map(|row| row.map(|v| v / big));
    }
    libm::exp(log_scale / libm::pow(2.0, SQUARINGS as f64))
}
