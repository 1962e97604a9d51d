//! Calibration with the physics split (`beam calibrate --method split`): first the beam, on
//! the root strain with the hub prescribed from the logged angle, where torque and motor
//! errors cannot leak in; then the rigid body and friction, on the hub angle driven by the
//! logged torque, with a torque scale among the unknowns.
//!
//! With the hub prescribed and the gauge's scale free, the strain fixes EI/rho (frequency
//! and amplitude both go with it), the modal damping and the gauge; the density, and with it
//! EI at that ratio, comes from the torque side, where it trades with Jm.

use crate::calibrate::{minimise, replay, CalibrateError, Experiment, Windows};
use crate::optimize::Param;
use crate::replay::replay_prescribed;
use model_core::{Beam, BeamParams};

/// What the split found besides the beam's parameters.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct SplitReport {
    /// The strain gauge's reading over the strain the model implies.
    pub gauge_scale: f64,
    /// The logged torque over the torque the hub received.
    pub torque_scale: f64,
    /// RMS root-strain error of the beam step (hub prescribed, gauge scale applied), ue.
    pub beam_rms_strain_err_ue: f64,
    /// RMS hub-angle error of the rigid step (torque open loop, scale applied), rad.
    pub rigid_rms_theta_err_rad: f64,
}

fn window(w: &Windows) -> (f64, f64) {
    (0.0, w.settle_end_s)
}

/// Fits one parameter set to all `exps` from `guess` with an `N`-mode model.
pub fn calibrate_split<const N: usize>(
    exps: &[Experiment],
    guess: &BeamParams,
    evals: usize,
) -> Result<(BeamParams, SplitReport), CalibrateError> {
    Beam::try_build(*guess)?;
    if exps.is_empty() {
        return Err(CalibrateError::NoLogs);
    }
    let g = *guess;
    // 1. The beam, hub prescribed: EI (at the guess's density: only EI/rho matters here),
    //    modal damping and the root gauge's position; the gauge scale in closed form.
    let beam_params = [
        Param {
            name: "ei_nm2",
            lo: g.ei_nm2 / 2.0,
            hi: g.ei_nm2 * 2.0,
            log: true,
        },
        Param {
            name: "damping_ratio",
            lo: 1e-3,
            hi: 0.2,
            log: true,
        },
        Param {
            name: "root_gauge_m",
            lo: 0.0,
            hi: 0.2 * g.length_m,
            log: false,
        },
    ];
    let beam_at = |u: &[f64]| BeamParams {
        ei_nm2: beam_params[0].gain_at(u[0]),
        damping_ratio: beam_params[1].gain_at(u[1]),
        root_gauge_m: beam_params[2].gain_at(u[2]),
        ..g
    };
    // Sums of model*measured, model^2, measured^2 over every log's window (ue).
    let strain_sums = |p: &BeamParams| -> Option<(f64, f64, f64, usize)> {
        let (mut pm, mut pp, mut mm, mut n) = (0.0, 0.0, 0.0, 0usize);
        for e in exps {
            let eps = replay_prescribed::<N>(p, &e.log)?;
            let (a, b) = window(&e.windows);
            for (k, model) in eps.iter().enumerate() {
                let t = e.log.t[k] - e.log.t[0];
                if t >= a - 1e-9 && t <= b + 1e-9 {
                    let (x, y) = (model * 1e6, e.log.root_strain[k] * 1e6);
                    pm += x * y;
                    pp += x * x;
                    mm += y * y;
                    n += 1;
                }
            }
        }
        Some((pm, pp, mm, n))
    };
    // With the best gauge scale s = pm/pp, the residual is mm - pm^2/pp.
    let beam_cost = |u: &[f64]| -> f64 {
        match strain_sums(&beam_at(u)) {
            Some((pm, pp, mm, n)) if pp > 0.0 => {
                ((mm - pm * pm / pp).max(0.0) / n as f64 + 1e-12).ln()
            }
            _ => 1e3,
        }
    };
    let start: Vec<f64> = beam_params
        .iter()
        .zip([g.ei_nm2, g.damping_ratio.max(1e-3), g.root_gauge_m])
        .map(|(p, v)| p.unit_of(v))
        .collect();
    let ub = minimise(3, start, evals, 0x5B17 ^ 3, &beam_cost);
    let beam = beam_at(&ub);
    let (pm, pp, mm, n) = strain_sums(&beam).ok_or(CalibrateError::Breakdown { step: "beam" })?;
    let gauge_scale = if pp > 0.0 { pm / pp } else { 1.0 };
    let beam_err = ((mm - pm * pm / pp.max(1e-300)).max(0.0) / n.max(1) as f64).sqrt();
    let ratio = beam.ei_nm2 / beam.density_kg_m3;
    // 2. The rigid body and friction, torque open loop: Jm, density (EI follows at the
    //    ratio), viscous and Coulomb friction, and the torque scale.
    let rigid_params = [
        Param {
            name: "jm_kgm2",
            lo: g.jm_kgm2 / 3.0,
            hi: g.jm_kgm2 * 3.0,
            log: true,
        },
        Param {
            name: "density_kg_m3",
            lo: g.density_kg_m3 / 2.0,
            hi: g.density_kg_m3 * 2.0,
            log: true,
        },
        Param {
            name: "viscous_nms",
            lo: 1e-6,
            hi: (10.0 * g.viscous_nms).max(0.05),
            log: true,
        },
        Param {
            name: "coulomb_nm",
            lo: 0.0,
            hi: (4.0 * g.coulomb_nm).max(0.1),
            log: false,
        },
        Param {
            name: "torque_scale",
            lo: 0.7,
            hi: 1.3,
            log: false,
        },
    ];
    let rigid_at = |u: &[f64]| -> (BeamParams, f64) {
        let density = rigid_params[1].gain_at(u[1]);
        (
            BeamParams {
                jm_kgm2: rigid_params[0].gain_at(u[0]),
                density_kg_m3: density,
                ei_nm2: ratio * density,
                viscous_nms: rigid_params[2].gain_at(u[2]),
                coulomb_nm: rigid_params[3].gain_at(u[3]),
                ..beam
            },
            rigid_params[4].gain_at(u[4]),
        )
    };
    let hub_sq = |p: &BeamParams, scale: f64| -> Option<(f64, usize)> {
        let (mut se, mut n) = (0.0, 0usize);
        for e in exps {
            let mut log = e.log.clone();
            log.torque.iter_mut().for_each(|u| *u /= scale);
            let (a, b) = window(&e.windows);
            let (th, _) = replay::<N>(p, &log, b)?;
            for (k, th) in th.iter().enumerate() {
                let t = log.t[k] - log.t[0];
                if t >= a - 1e-9 && t <= b + 1e-9 {
                    se += (th - log.theta[k]).powi(2);
                    n += 1;
                }
            }
        }
        Some((se, n))
    };
    let rigid_cost = |u: &[f64]| -> f64 {
        let (p, s) = rigid_at(u);
        hub_sq(&p, s).map_or(1e3, |(se, n)| (se / n.max(1) as f64 + 1e-20).ln())
    };
    let start: Vec<f64> = rigid_params
        .iter()
        .zip([
            g.jm_kgm2,
            g.density_kg_m3,
            g.viscous_nms.max(1e-6),
            g.coulomb_nm,
            1.0,
        ])
        .map(|(p, v)| p.unit_of(v))
        .collect();
    let ur = minimise(5, start, evals, 0x5B17 ^ 5, &rigid_cost);
    let (found, torque_scale) = rigid_at(&ur);
    let (se, n) =
        hub_sq(&found, torque_scale).ok_or(CalibrateError::Breakdown { step: "rigid" })?;
    Ok((
        found,
        SplitReport {
            gauge_scale,
            torque_scale,
            beam_rms_strain_err_ue: beam_err,
            rigid_rms_theta_err_rad: (se / n.max(1) as f64).sqrt(),
        },
    ))
}
