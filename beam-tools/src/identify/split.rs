//! Calibration with the physics split (`beam calibrate --method split`).
//!
//! 1. **The beam**, on the root strain with the hub prescribed from the logged angle, where
//!    torque and motor errors cannot leak in: EI/rho (the strain's frequency and its
//!    amplitude per unit of hub motion both go with the ratio alone), the modal damping, the
//!    gauge's position and, in closed form, the gauge's scale.
//! 2. **The rigid body and friction**, from a torque balance on the hub, sample by sample
//!    while it moves: the logged torque against `Jm alpha + R + c omega + Fc sgn(omega)` and
//!    an offset, with `alpha` and `omega` from the logged angle and `R` the torque the beam
//!    takes from the hub (the prescribed replay of step 1, proportional to the density at the
//!    ratio found). That is linear least squares: no open-loop replay, so no torque error
//!    integrated twice into the hub angle, and no search.
//!
//! **What one rig's logs cannot tell.** Scaling Jm, density, EI, both friction terms and the
//! torque's scale together leaves every logged signal unchanged (the beam's equation
//! depends on EI/rho only, the strain on the curvature, and the hub's equation is linear
//! in the rest; `beam-sim/tests/physics.rs` checks it). So the torque balance gives
//! `s Jm`, `s rho`, `s c` and `s Fc` for an unknown torque scale `s`, and one more fact
//! fixes the level: either the torque reads true (`s = 1`, the default), or the beam's
//! density is known (a material's handbook value, `--known-density`), or the same move is
//! logged again with a weighed mass added at the tip (`--tip-masses`, the mass-change
//! method of modal testing: the beam's frequency falls by how heavy the mass is against
//! the beam, which gives its density). The last two then measure the torque's scale.
//!
//! Step 1's search ends with Levenberg-Marquardt steps: the density against EI/rho is a
//! long valley that a derivative-free search stops short in.
//!
//! Standard errors: step 1's from the Gauss-Newton approximation on the strain, with the
//! residuals' lag-one autocorrelation counted (fewer independent samples than logged);
//! step 2's from a moving-block bootstrap of the balance's samples.

use crate::design::optimize::Param;
use crate::identify::calibrate::{
    lagged, minimise, replay, AtBound, BeamSensor, CalibrateError, Experiment, Log, Tradeoff,
    Uncertainty, UnphysicalCause,
};
use crate::identify::lsq::Normal;
use crate::identify::replay::{
    beam_plant, corrected, encoder_step, hub_window_s, prescribed_observed, prescribed_on,
    requantised, HubMotion, StrainObserver, ENCODER_PHASES, HUB_WINDOW_S, MAX_STRAIN_DELAY_S,
};
use crate::io::params_file::Sensors;
use beam_sim::plant::{Plant, COULOMB_SMOOTHING_RAD_S};
use model_core::{Beam, BeamParams};
use rand::{rngs::StdRng, Rng, SeedableRng};
use rayon::prelude::*;

/// What fixes the level of the masses, stiffness and friction (see the module's docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Reference {
    /// The logged torque reads true: the torque scale is 1.
    Torque,
    /// The beam's density is known, kg/m^3: the torque scale is measured.
    Density(f64),
    /// The logs were recorded with at least two different weighed tip masses (each
    /// [`Experiment`]'s, or the parameters'): the mass-change method of modal testing. A
    /// known mass breaks the scaling, since the beam's frequencies fall with it by how heavy
    /// it is against the beam; step 1 fits the density beside EI/rho on all the logs, and
    /// the torque scale is measured as with a known density. One mass alone is refused: on
    /// a smooth move it moves the strain too little to tell from the model's own error
    /// (the other rig with 0.1 kg: density -15 % at six of its sigmas).
    TipMass,
}

impl Reference {
    /// Whether the torque's scale is measured (the level fixed by something else).
    fn measures_scale(self) -> bool {
        !matches!(self, Reference::Torque)
    }

    /// The report's name of the reference.
    fn name(self) -> &'static str {
        match self {
            Reference::Torque => "torque",
            Reference::Density(_) => "density",
            Reference::TipMass => "tip_mass",
        }
    }
}

/// A sample counts as moving, for the torque balance, above this fraction of the log's
/// peak hub rate: near rest the friction is static (anything up to Fc) and the balance's
/// `sgn(omega)` does not hold.
pub const MOVING_FRACTION: f64 = 0.05;

/// Bootstrap resamples of the torque balance.
pub const BOOTSTRAP: usize = 400;

/// The shortest block of the bootstrap, s: twice the balance's interval, over which
/// neighbouring rows share samples. Blocks are longer where the residuals stay correlated
/// longer: twice the lag at which their autocorrelation first falls below 1/e.
pub const MIN_BLOCK_S: f64 = 2.0 * BALANCE_INTERVAL_S;

/// An offset can be fitted only when the logs move both ways, each for at least this
/// fraction of the balance's intervals: moving one way, Coulomb friction and an offset are
/// the same constant.
pub const BOTH_WAYS_FRACTION: f64 = 0.2;

/// What the split found besides the beam's parameters.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct SplitReport {
    /// The rig's instruments: torque scale (fitted unless the torque is the reference), torque
    /// offset, gauge scale.
    pub sensors: Sensors,
    /// `torque`, `density` or `tip_mass`: what fixed the level.
    pub reference: &'static str,
    /// Whether the torque offset was fitted (asked for, and the logs move both ways).
    pub offset_fitted: bool,
    /// What the beam step fitted: `root strain` or `tip deflection` ([`BeamSensor::name`]).
    pub beam_signal: &'static str,
    /// RMS error of the beam step (hub prescribed, gauge scale applied), in `beam_unit`.
    pub beam_rms_err: f64,
    /// The unit of `beam_rms_err`: `ue` (root strain) or `mm` (tip deflection).
    pub beam_unit: &'static str,
    /// How much later than the delay already taken out of the logs the beam sensor reads,
    /// fitted with the beam ([`SplitOptions::fit_lag`]; 0 when not fitted), s. The caller
    /// takes it out of the logs and calibrates again (the polish keeps none within a
    /// sample and a half).
    pub beam_lag_s: f64,
    /// Samples in the torque balance.
    pub balance_samples: usize,
    /// RMS of the balance's residual, N m.
    pub balance_rms_err_nm: f64,
    /// RMS of the logged torque over the same samples, N m.
    pub balance_rms_torque_nm: f64,
    /// RMS hub-angle error of the torque replayed open loop through the found sensors,
    /// over every log's move and settling, rad (a check, not fitted: it drifts).
    pub replay_rms_theta_err_rad: f64,
    /// The largest angle any log's hub covers over its move and settling, rad.
    pub move_span_rad: f64,
    /// One-sigma errors.
    pub uncertainty: Vec<Uncertainty>,
    /// Pairs the logs do not tell apart.
    pub tradeoffs: Vec<Tradeoff>,
    /// How far the torque balance's results move with the prescribed hub smoothed
    /// differently (counted in `uncertainty`).
    pub window_shift: Vec<WindowShift>,
    /// Each log's encoder step found in its angle, or given, rad (`None`: not on a grid, so
    /// no encoder term from it).
    pub encoder_step_rad: Vec<Option<f64>>,
    /// The step was given (`SplitOptions::encoder_step_rad`), not found.
    pub encoder_step_given: bool,
    /// Parameters that ended on a bound: of step 1's search, or friction the balance found
    /// negative and that was set to zero.
    pub at_bound: Vec<AtBound>,
    /// With no offset asked for, a torque the balance could not place in either direction
    /// of motion, found by fitting an offset too; when set, the offset was fitted for it
    /// (`offset_fitted`). `None`: none, or not testable.
    pub unplaced_offset: Option<UnplacedOffset>,
}

/// Step 1's global search stops each local search when its step is below this (relative,
/// on the unit cube): it has only to land in the basin that the Gauss-Newton polish then
/// converges in. On the lab link's log a tolerance of 1e-6 spent 8.6 s of a 9 s step in
/// the search, 1e-2 spent 0.34 s, and the polished beam agreed to ten digits.
pub const BEAM_SEARCH_XTOL: f64 = 1e-2;

/// The prescribed hub's half-width is multiplied by these to see how much the results
/// depend on it, within [`HUB_WINDOW_S`] (below 5 ms the encoder's steps, not the model,
/// would move them). Not doubled: the half-width is a quarter period of the second mode,
/// and at twice that the hub loses the mode (on the drive's own log of the aluminium beam
/// doubling moved EI by 3 times its noise, where it was 0.13 % off).
pub const WINDOW_FACTORS: [f64; 2] = [0.5, core::f64::consts::SQRT_2];

/// `beam calibrate` warns when a result moves by more than this many times its noise with
/// the hub smoothed differently or its angle quantised again. (On the drive's own log the
/// damping's and the gauge scale's exceed it; before the balance's beam followed the strain,
/// the other rig's backward log moved Jm by 21 times its noise.)
pub const WINDOW_WARNING: f64 = 2.0;

/// `beam calibrate` warns when the open-loop replay drifts by more than this fraction of the
/// move ([`SplitReport::replay_drifts`]). On the other rig's logs it drifts 0.1 to 0.2 %
/// of the 60 deg move; a bare log said to carry a 0.1 kg tip mass, 31 %.
pub const REPLAY_WARNING: f64 = 0.1;

impl SplitReport {
    /// Whether the found model, driven open loop by the logged torque through the found
    /// sensors, drifts from the logged angle by more than [`REPLAY_WARNING`] of the move:
    /// the torque balance then fitted numbers that do not explain the torque, and the logs
    /// and the starting parameters (a tip mass, the gauge) likely disagree. The balance's
    /// beam follows the logged strain, which keeps it from saying so itself.
    pub fn replay_drifts(&self) -> bool {
        self.replay_rms_theta_err_rad > REPLAY_WARNING * self.move_span_rad
    }
}

/// How much a result depends on the prescribed hub's smoothing: a model error (the beam
/// driven by a hub smoother than the real one), which neither the Gauss-Newton intervals
/// nor the bootstrap see. Step 1's shift is its fit polished again (Levenberg-Marquardt
/// from the result) on the strain of the beam driven by each other hub; step 2's, the
/// balance refitted with R from it. The encoder's part is the RMS shift with the angle
/// quantised again (docs/results.md, "Calibration on other rigs", for the figures).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct WindowShift {
    /// The parameter.
    pub name: &'static str,
    /// Its standard error from the bootstrap (the noise alone).
    pub noise: f64,
    /// The larger of its shifts with the half-width times each of [`WINDOW_FACTORS`].
    pub shift: f64,
    /// The RMS of its shifts with the logged angle smoothed and quantised again to the
    /// encoder's step at each of [`ENCODER_PHASES`] (zero if no log's angle is quantised):
    /// the encoder's error, which enters as the beam's input and so is not in the noise.
    pub encoder: f64,
}

fn in_window(e: &Experiment, k: usize) -> bool {
    let t = e.log.t[k] - e.log.t[0];
    t >= e.windows.start_s - 1e-9 && t <= e.windows.settle_end_s + 1e-9
}

/// Step 1's result.
struct BeamFit {
    params: BeamParams,
    gauge_scale: f64,
    /// RMS error of the fit, in the beam signal's display unit ([`BeamSensor::unit`]).
    rms_err: f64,
    /// The sensor's lag beyond the logs' own, fitted with the beam, s (0 if not fitted).
    lag_s: f64,
    /// Standard errors of ln EI/rho, ln damping, gauge position, gauge scale, ln rho (zero
    /// where held).
    std_err: [f64; 5],
    corr: [[f64; 5]; 5],
    /// Standard error of ln EI (ln EI/rho plus ln rho, with their covariance).
    ln_ei_std_err: f64,
    /// The larger shift of each, in the same slots, with the hub smoothed differently
    /// ([`WINDOW_FACTORS`]).
    shift: [f64; 5],
    /// The same for ln EI.
    ln_ei_shift: f64,
    /// The RMS shift of each, in the same slots, with the angle re-quantised
    /// ([`ENCODER_PHASES`]).
    encoder: [f64; 5],
    /// The same for ln EI.
    ln_ei_encoder: f64,
    /// The searched coordinates that ended on a bound of the search.
    at_bound: Vec<AtBound>,
}

/// One row of the torque balance.
#[derive(Clone, Copy, Debug)]
struct Row {
    x: [f64; 5],
    y: f64,
}

/// How the split runs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SplitOptions {
    /// What fixes the level.
    pub reference: Reference,
    /// Fit the root gauge's position too. Off by default: it trades almost exactly against
    /// the gauge's scale (correlation 0.997 on the other-rig log, which found 77 mm and a
    /// scale of 1.23 for a gauge at the root reading true), and a position found that way
    /// gives a model whose strain is not the gauge's reading. A ruler measures it better.
    pub fit_gauge_position: bool,
    /// Fit a torque offset (the logs must move both ways). Off by default: on a PD slew
    /// that swings back and forth it found 0.027 +- 0.005 N m where there is none (the
    /// aluminium beam, 0.8 s; the swings back are short and fast, and the offset soaks up
    /// what the model misses there).
    pub fit_offset: bool,
    /// Fit, in step 1's polish, how much later the beam sensor reads than the delay already
    /// taken out of the logs ([`SplitReport::beam_lag_s`]). A lag found by correlation on
    /// the starting model is off by what that model's frequency is, and the beam's fit then
    /// takes the lag's error as a frequency error; fitted with the beam, the two part. Off
    /// when the user gives the delay.
    pub fit_lag: bool,
    /// COBYLA evaluations per local search of step 1.
    pub evals: usize,
    /// The encoder's step, rad, when the user gives it; `None`: found in each log's angle
    /// ([`encoder_step`]), which cannot tell an encoder's step from a log's decimal rounding
    /// when the rounding is the coarser.
    pub encoder_step_rad: Option<f64>,
}

/// The sensor every log measures the beam with; an error if they differ (one fit pools the
/// residuals, which must share a unit).
fn one_sensor(exps: &[Experiment]) -> Result<BeamSensor, CalibrateError> {
    let first = exps.first().ok_or(CalibrateError::NoLogs)?.log.sensor;
    match exps.iter().find(|e| e.log.sensor != first) {
        Some(other) => Err(CalibrateError::MixedSensors(
            first.name(),
            other.log.sensor.name(),
        )),
        None => Ok(first),
    }
}

/// Fits one parameter set to all `exps` from `guess` with an `N`-mode model. Returns the
/// beam, the rig's sensors and the report.
///
/// Step 1 is the beam on the prescribed hub (`fit_beam`), step 2 the torque balance,
/// iterated on the density when the torque is the reference (`solve_balance`); then come
/// the balance's spread (`balance_spread`), the intervals and trade-offs of both steps,
/// and the check figures.
pub fn calibrate_split<const N: usize>(
    exps: &[Experiment],
    guess: &BeamParams,
    options: &SplitOptions,
) -> Result<(BeamParams, Sensors, SplitReport), CalibrateError> {
    let reference = options.reference;
    let sensor = one_sensor(exps)?;
    if options.fit_gauge_position && sensor != BeamSensor::RootStrain {
        return Err(CalibrateError::SensorUnsupported(
            "the root gauge's position cannot be fitted on a log without a root gauge (it \
             measures the tip's deflection)",
        ));
    }
    let g = starting_params(exps, guess, reference)?;
    let window = hub_window_s(&g);
    let views = HubViews::of(exps, window, options.encoder_step_rad);
    let beam = fit_beam::<N>(
        exps,
        &views.hubs,
        &views.alt_hubs,
        &views.enc_hubs,
        &g,
        options,
    )?;
    // The balance's rates from a short fit: it needs them only at the intervals' ends,
    // where the encoder's noise is averaged by the interval, while a wide fit's smoothing
    // is a bias that correlates with the motion.
    let rates: Vec<HubMotion> = exps
        .iter()
        .map(|e| HubMotion::of(&e.log, BALANCE_RATE_WINDOW_S))
        .collect();
    // The balance's beam follows the logged strain (a steady-state Kalman correction), so
    // that vibration the prescribed hub does not carry is in R: a hub chattering within an
    // encoder count at the start of the backward log excites the beam, and without the
    // correction that log gave Jm half the truth and the torque scale 1.20 (truth 1.05).
    // The hub's acceleration error, the process noise, is taken as how far it moves with
    // the half-width halved; the strain's, as step 1's residual.
    let observers: Vec<StrainObserver> = views
        .hubs
        .iter()
        .zip(&views.alt_hubs[0])
        .map(|(h, a)| StrainObserver {
            gauge_scale: beam.gauge_scale,
            alpha_err: h.alpha_rms_diff(a),
            strain_err: beam.rms_err / sensor.display_scale(),
        })
        .collect();
    let inputs = BalanceInputs {
        exps,
        rates: &rates,
        observers: &observers,
    };
    let first = rigid_body::<N>(&inputs, &views, &beam, options)?;
    // A torque the balance could not place in either direction ([`unplaced_offset`]): the
    // rigid body again with an offset (step 1, the beam, does not depend on it), and said.
    match first.2.unplaced_offset {
        Some(u) => {
            let with_offset = SplitOptions {
                fit_offset: true,
                ..*options
            };
            let (found, sensors, mut report) =
                rigid_body::<N>(&inputs, &views, &beam, &with_offset)?;
            report.unplaced_offset = Some(u);
            Ok((found, sensors, report))
        }
        None => Ok(first),
    }
}

/// Step 2 and what follows it, on step 1's `beam`: the torque balance, its spread, the
/// intervals and trade-offs of both steps, and the check figures.
fn rigid_body<const N: usize>(
    inputs: &BalanceInputs,
    views: &HubViews,
    beam: &BeamFit,
    options: &SplitOptions,
) -> Result<(BeamParams, Sensors, SplitReport), CalibrateError> {
    let (exps, reference) = (inputs.exps, options.reference);
    let balance = solve_balance::<N>(inputs, &views.hubs, &beam.params, options)?;
    let d = balance.derived(&balance.coef, reference);
    if !physical(&d) {
        return Err(CalibrateError::Unphysical {
            jm: d[0],
            density: d[1],
            torque_scale: d[4],
            cause: unphysical_cause(&balance, reference),
        });
    }
    // Friction cannot be negative: a balance that finds it so is held at zero, and said.
    let mut at_bound = beam.at_bound.clone();
    for (name, value) in [("viscous_nms", d[2]), ("coulomb_nm", d[3])] {
        if value < 0.0 {
            at_bound.push(AtBound {
                name,
                value,
                bound: 0.0,
                side: "lower",
            });
        }
    }
    let rigid = || CalibrateError::Breakdown { step: "rigid" };
    let found = BeamParams {
        jm_kgm2: d[0],
        viscous_nms: d[2].max(0.0),
        coulomb_nm: d[3].max(0.0),
        ..at_density::<N>(&beam.params, exps, d[1]).ok_or_else(rigid)?
    };
    let sensors = Sensors {
        torque_scale: d[4],
        torque_offset_nm: d[5],
        gauge_scale: beam.gauge_scale,
        // The logs' own delay is the caller's: it took it out before the split saw them.
        strain_delay_s: 0.0,
    };
    let spread = balance_spread::<N>(inputs, views, &balance, &d, reference)?;
    let window_shift = window_shifts(&spread, beam, &balance.params, options);
    let uncertainty = uncertainties(
        &spread,
        beam,
        &found,
        &sensors,
        options,
        balance.offset_fitted,
    );
    let tradeoffs = tradeoffs(&spread, beam);
    let check = check_figures::<N>(exps, &balance, &found, &sensors)?;
    let unplaced_offset = unplaced_offset(exps, &balance, reference, check.balance_rms_err_nm);
    Ok((
        found,
        sensors,
        SplitReport {
            sensors,
            reference: reference.name(),
            offset_fitted: balance.offset_fitted,
            beam_signal: exps[0].log.sensor.name(),
            beam_rms_err: beam.rms_err,
            beam_lag_s: beam.lag_s,
            beam_unit: exps[0].log.sensor.unit(),
            balance_samples: balance.rows.len(),
            balance_rms_err_nm: check.balance_rms_err_nm,
            balance_rms_torque_nm: check.balance_rms_torque_nm,
            replay_rms_theta_err_rad: check.replay_rms_theta_err_rad,
            move_span_rad: check.move_span_rad,
            uncertainty,
            tradeoffs,
            window_shift,
            encoder_step_rad: views.steps.clone(),
            encoder_step_given: options.encoder_step_rad.is_some(),
            at_bound,
            unplaced_offset,
        },
    ))
}

/// Jm, the density and the torque scale of derived balance results are all positive.
fn physical(d: &[f64; 6]) -> bool {
    d[0] > 0.0 && d[1] > 0.0 && d[4] > 0.0
}

/// The rows' moves go both ways, each for at least [`BOTH_WAYS_FRACTION`] of them (the
/// Coulomb column carries each interval's direction).
fn moves_both_ways(rows: &[Row]) -> bool {
    let up = rows.iter().filter(|r| r.x[3] > 0.0).count();
    let down = rows.iter().filter(|r| r.x[3] < 0.0).count();
    up.min(down) as f64 >= BOTH_WAYS_FRACTION * (up + down) as f64
}

/// Why `balance` (unphysical) most likely is: if it moves both ways without an offset and
/// the same rows with one give a physical result, the offset.
fn unphysical_cause(balance: &Balance, reference: Reference) -> UnphysicalCause {
    if balance.offset_fitted || !moves_both_ways(&balance.rows) {
        return UnphysicalCause::Unknown;
    }
    match fit_balance(&balance.rows, true).map(|c| balance.derived(&c, reference)) {
        Ok(d) if physical(&d) => UnphysicalCause::Offset {
            offset_nm: d[5],
            jm: d[0],
        },
        _ => UnphysicalCause::Unknown,
    }
}

/// How many of its standard errors an offset the balance was not asked for must be, when
/// the balance is refitted with one, to be reported (and fitted by default).
pub const UNPLACED_SIGMAS: f64 = 4.0;
/// See [`UNPLACED_SIGMAS`]: the residual's RMS with the offset must be at most this fraction
/// of it without.
pub const UNPLACED_RMS_RATIO: f64 = 0.5;

/// With no offset fitted and the logs moving both ways, the balance refitted with one;
/// returned when the offset is more than [`UNPLACED_SIGMAS`] of its block-bootstrap error
/// and the residual's RMS falls to [`UNPLACED_RMS_RATIO`] of `rms_without` or less: a torque
/// the balance could not place in either direction, which a torque offset or Coulomb friction
/// that differs between the directions leaves. (Off by default because a log swinging back
/// and forth can show a small offset that is not there; the residual's fall tells the two
/// apart: a true 50 mN m offset took it from 2.5e-3 to 2.6e-4 N m, the spurious ones leave
/// it where it was.)
fn unplaced_offset(
    exps: &[Experiment],
    balance: &Balance,
    reference: Reference,
    rms_without: f64,
) -> Option<UnplacedOffset> {
    if balance.offset_fitted || !moves_both_ways(&balance.rows) {
        return None;
    }
    let coef = fit_balance(&balance.rows, true).ok()?;
    let resid: Vec<f64> = balance
        .rows
        .iter()
        .map(|r| r.y - r.x.iter().zip(&coef).map(|(x, c)| x * c).sum::<f64>())
        .collect();
    let rms_with = (resid.iter().map(|r| r * r).sum::<f64>() / resid.len().max(1) as f64).sqrt();
    let dt0 = exps[0].log.t[1] - exps[0].log.t[0];
    let block_s = (2.0 * decorrelation_lag(&resid) as f64 * dt0).max(MIN_BLOCK_S);
    let boot: Vec<f64> = bootstrap(&balance.rows, exps, true, block_s)
        .into_iter()
        .map(|c| balance.derived(&c, reference)[5])
        .collect();
    let n = boot.len().max(1) as f64;
    let mean = boot.iter().sum::<f64>() / n;
    let std_err = (boot.iter().map(|b| (b - mean).powi(2)).sum::<f64>() / n).sqrt();
    let offset_nm = balance.derived(&coef, reference)[5];
    (offset_nm.abs() > UNPLACED_SIGMAS * std_err && rms_with <= UNPLACED_RMS_RATIO * rms_without)
        .then_some(UnplacedOffset {
            offset_nm,
            std_err_nm: std_err,
            rms_err_with_nm: rms_with,
            rms_err_without_nm: rms_without,
        })
}

/// A torque the balance could not place in either direction of motion, found by refitting
/// the balance with an offset.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct UnplacedOffset {
    /// The offset the balance finds when it is given one, N m.
    pub offset_nm: f64,
    /// Its one-sigma error (block bootstrap), N m.
    pub std_err_nm: f64,
    /// The balance's residual RMS with it, N m.
    pub rms_err_with_nm: f64,
    /// The balance's residual RMS without it, N m.
    pub rms_err_without_nm: f64,
}

/// `guess` checked, with a known density put in (EI moved with it, at the ratio), and the
/// logs checked against the reference.
fn starting_params(
    exps: &[Experiment],
    guess: &BeamParams,
    reference: Reference,
) -> Result<BeamParams, CalibrateError> {
    Beam::try_build(*guess)?;
    if exps.is_empty() {
        return Err(CalibrateError::NoLogs);
    }
    let mut g = *guess;
    if let Reference::Density(rho) = reference {
        if !(rho.is_finite() && rho > 0.0) {
            return Err(CalibrateError::Reference(rho));
        }
        g.ei_nm2 *= rho / g.density_kg_m3;
        g.density_kg_m3 = rho;
    }
    if reference == Reference::TipMass {
        let m0 = exps[0].params(&g).tip_mass_kg;
        if exps.iter().all(|e| e.params(&g).tip_mass_kg == m0) {
            return Err(CalibrateError::OneTipMass);
        }
    }
    Ok(g)
}

/// The prescribed hub of each log, as fitted and as the results' sensitivities need it.
struct HubViews {
    /// At the chosen smoothing width.
    hubs: Vec<HubMotion>,
    /// At each of [`WINDOW_FACTORS`] times the width.
    alt_hubs: Vec<Vec<HubMotion>>,
    /// Each log's angle quantised again at each of [`ENCODER_PHASES`] of its encoder's step
    /// (logs not on a grid as logged); empty when no log is.
    requantised_logs: Vec<Vec<Log>>,
    /// The hub of each of those.
    enc_hubs: Vec<Vec<HubMotion>>,
    /// Each log's encoder step, rad.
    steps: Vec<Option<f64>>,
}

impl HubViews {
    fn of(exps: &[Experiment], window: f64, given_step: Option<f64>) -> Self {
        let hubs = exps.iter().map(|e| HubMotion::of(&e.log, window)).collect();
        let alt_hubs = WINDOW_FACTORS
            .iter()
            .map(|f| {
                exps.iter()
                    .map(|e| {
                        HubMotion::of(&e.log, (window * f).clamp(HUB_WINDOW_S.0, HUB_WINDOW_S.1))
                    })
                    .collect()
            })
            .collect();
        let dt = exps[0].log.t[1] - exps[0].log.t[0];
        let half = ((window / dt).round() as usize).max(2);
        let steps: Vec<Option<f64>> = exps
            .iter()
            .map(|e| given_step.or_else(|| encoder_step(&e.log.theta)))
            .collect();
        let requantised_logs: Vec<Vec<Log>> = if steps.iter().any(Option::is_some) {
            ENCODER_PHASES
                .iter()
                .map(|&phase| {
                    exps.iter()
                        .zip(&steps)
                        .map(|(e, step)| match step {
                            Some(q) => requantised(&e.log, half, *q, phase),
                            None => e.log.clone(),
                        })
                        .collect()
                })
                .collect()
        } else {
            vec![]
        };
        let enc_hubs = requantised_logs
            .iter()
            .map(|logs| logs.iter().map(|l| HubMotion::of(l, window)).collect())
            .collect();
        Self {
            hubs,
            alt_hubs,
            requantised_logs,
            enc_hubs,
            steps,
        }
    }
}

/// What every run of the torque balance shares.
struct BalanceInputs<'a> {
    exps: &'a [Experiment],
    /// The hub's rates at the intervals' ends.
    rates: &'a [HubMotion],
    /// The strain observers of the balance's beam.
    observers: &'a [StrainObserver],
}

/// Step 2's result.
struct Balance {
    /// The beam the balance ran on (step 1's, its density iterated with a trusted torque).
    params: BeamParams,
    rows: Vec<Row>,
    /// Jm, the density's factor (or the torque scale), viscous, Coulomb, offset, as fitted.
    coef: [f64; 5],
    offset_fitted: bool,
}

impl Balance {
    /// `c` as the physical results: [Jm, density, viscous, Coulomb, torque scale, offset].
    fn derived(&self, c: &[f64; 5], reference: Reference) -> [f64; 6] {
        let p = &self.params;
        let s = match reference {
            Reference::Torque => 1.0,
            _ => c[1],
        };
        let density = match reference {
            Reference::Torque => p.density_kg_m3 * c[1],
            Reference::Density(rho) => rho,
            // Step 1's.
            Reference::TipMass => p.density_kg_m3,
        };
        [c[0] / s, density, c[2] / s, c[3] / s, s, c[4]]
    }
}

/// Step 1's `beam` at another density: EI with it at step 1's ratio, and then, where a tip
/// mass makes the frequencies depend on the density at a given ratio (the tip weighs less
/// against a denser beam), scaled to hold step 1's first clamped mode on the first log's
/// beam, which the logged signal fixed. At fixed masses the frequencies go with the square
/// root of EI, so one step holds it exactly. `None` if that is not a beam.
fn at_density<const N: usize>(
    beam: &BeamParams,
    exps: &[Experiment],
    density: f64,
) -> Option<BeamParams> {
    let first_hz = |q: &BeamParams| -> Option<f64> {
        let q = exps.first().map_or(*q, |e| e.params(q));
        let model = model_core::ModalModel::<N>::try_build(&Beam::try_build(q).ok()?).ok()?;
        Some(model.clamped_hz[0])
    };
    let mut p = BeamParams {
        density_kg_m3: density,
        ei_nm2: beam.ei_nm2 / beam.density_kg_m3 * density,
        ..*beam
    };
    Beam::try_build(p).ok()?;
    if let (Some(want), Some(now)) = (first_hz(beam), first_hz(&p)) {
        p.ei_nm2 *= (want / now).powi(2);
    }
    Beam::try_build(p).ok().map(|_| p)
}

/// Step 2, the torque balance on `hubs`. R scales with the density at the ratio (without a
/// tip mass, exactly; with one, nearly), so iterate on the density with the trusted torque,
/// EI following it to hold step 1's first mode ([`at_density`]; rescaled at the ratio, a
/// balance 10 % off in density moved the lab link's first mode 2.8 % off what step 1
/// found).
fn solve_balance<const N: usize>(
    inputs: &BalanceInputs,
    hubs: &[HubMotion],
    beam: &BeamParams,
    options: &SplitOptions,
) -> Result<Balance, CalibrateError> {
    let mut p = *beam;
    let mut rows = vec![];
    let mut offset_fitted = false;
    let mut coef = [0.0; 5];
    for _ in 0..6 {
        let both_ways;
        (rows, both_ways) =
            balance_rows::<N>(inputs.exps, hubs, inputs.rates, &p, inputs.observers)?;
        if options.fit_offset && !both_ways {
            return Err(CalibrateError::OneWay);
        }
        offset_fitted = options.fit_offset;
        coef = fit_balance(&rows, offset_fitted)?;
        let scale_now = coef[1];
        if options.reference.measures_scale() || (scale_now - 1.0).abs() < 1e-9 {
            break;
        }
        // A balance that wants no beam, or a negative one, is the logs' answer, not the
        // model's breakdown: say what it found.
        let unphysical = CalibrateError::Unphysical {
            jm: coef[0],
            density: p.density_kg_m3 * scale_now,
            torque_scale: 1.0,
            cause: UnphysicalCause::Unknown,
        };
        // Nor is a density beyond a factor of 3 from step 1's (the starting one, with the
        // torque as the reference; the range step 1 searches when it fits one): a bare log
        // said to carry a 0.1 kg tip ran the balance to 2 % of the strip's steel, where the
        // beam's model breaks down.
        let density = p.density_kg_m3 * scale_now;
        if !(scale_now > 0.0) || !(1.0 / 3.0..=3.0).contains(&(density / beam.density_kg_m3)) {
            return Err(unphysical);
        }
        p = at_density::<N>(beam, inputs.exps, density).ok_or(unphysical)?;
    }
    Ok(Balance {
        params: p,
        rows,
        coef,
        offset_fitted,
    })
}

/// The balance's results, named in [`Balance::derived`]'s order.
const BALANCE_NAMES: [&str; 6] = [
    "jm_kgm2",
    "density_kg_m3",
    "viscous_nms",
    "coulomb_nm",
    "torque_scale",
    "torque_offset_nm",
];

/// How well the balance's results are known: by a moving-block bootstrap (noise), and by
/// how far they move with the hub smoothed differently and the angle re-quantised (the
/// model's error, the encoder's).
struct BalanceSpread {
    /// The bootstrap's results, [`Balance::derived`] each.
    boot: Vec<[f64; 6]>,
    noise: Vec<f64>,
    shift: [f64; 6],
    encoder: [f64; 6],
    /// The three in quadrature.
    sd: Vec<f64>,
    /// The results this reference reports (indices into [`BALANCE_NAMES`]).
    used: Vec<usize>,
    reference: Reference,
}

fn balance_spread<const N: usize>(
    inputs: &BalanceInputs,
    views: &HubViews,
    balance: &Balance,
    d: &[f64; 6],
    reference: Reference,
) -> Result<BalanceSpread, CalibrateError> {
    let (exps, p, offset_fitted) = (inputs.exps, &balance.params, balance.offset_fitted);
    let resid: Vec<f64> = balance
        .rows
        .iter()
        .map(|r| {
            r.y - r
                .x
                .iter()
                .zip(&balance.coef)
                .map(|(x, c)| x * c)
                .sum::<f64>()
        })
        .collect();
    let dt0 = exps[0].log.t[1] - exps[0].log.t[0];
    let block_s = (2.0 * decorrelation_lag(&resid) as f64 * dt0).max(MIN_BLOCK_S);
    let boot = bootstrap(&balance.rows, exps, offset_fitted, block_s)
        .into_iter()
        .map(|c| balance.derived(&c, reference))
        .collect::<Vec<_>>();
    let mean_sd = |i: usize| -> f64 {
        let n = boot.len().max(1) as f64;
        let m = boot.iter().map(|b| b[i]).sum::<f64>() / n;
        (boot.iter().map(|b| (b[i] - m).powi(2)).sum::<f64>() / (n - 1.0).max(1.0)).sqrt()
    };
    // The model's error as the balance's sensitivity to the hub's smoothing, added to the
    // noise in quadrature.
    let mut shift = [0.0f64; 6];
    for alt in &views.alt_hubs {
        let (alt_rows, _) = balance_rows::<N>(exps, alt, inputs.rates, p, inputs.observers)?;
        let da = balance.derived(&fit_balance(&alt_rows, offset_fitted)?, reference);
        for (s, (a, b)) in shift.iter_mut().zip(da.iter().zip(d)) {
            *s = s.max((a - b).abs());
        }
    }
    // And to the encoder: the RMS shift over the re-quantised angles, the rates at the
    // intervals' ends taken from them too.
    let mut encoder = [0.0f64; 6];
    for (logs, hub) in views.requantised_logs.iter().zip(&views.enc_hubs) {
        let enc_rates: Vec<HubMotion> = logs
            .iter()
            .map(|l| HubMotion::of(l, BALANCE_RATE_WINDOW_S))
            .collect();
        let (alt_rows, _) = balance_rows::<N>(exps, hub, &enc_rates, p, inputs.observers)?;
        let da = balance.derived(&fit_balance(&alt_rows, offset_fitted)?, reference);
        for (s, (a, b)) in encoder.iter_mut().zip(da.iter().zip(d)) {
            *s += (a - b).powi(2) / ENCODER_PHASES.len() as f64;
        }
    }
    let encoder = encoder.map(f64::sqrt);
    let noise: Vec<f64> = (0..6).map(mean_sd).collect();
    let sd: Vec<f64> = (0..6)
        .map(|i| noise[i].hypot(shift[i]).hypot(encoder[i]))
        .collect();
    // The balance's results this reference reports.
    let used: Vec<usize> = (0..6)
        .filter(|&i| match i {
            1 => matches!(reference, Reference::Torque),
            4 => reference.measures_scale(),
            5 => offset_fitted,
            _ => true,
        })
        .collect();
    Ok(BalanceSpread {
        boot,
        noise,
        shift,
        encoder,
        sd,
        used,
        reference,
    })
}

/// Each result's noise, and its shifts with the hub's smoothing and the encoder: the
/// balance's, then step 1's in the parameters' units (EI's from EI/rho alone unless step 1
/// fits the density too).
fn window_shifts(
    spread: &BalanceSpread,
    beam: &BeamFit,
    p: &BeamParams,
    options: &SplitOptions,
) -> Vec<WindowShift> {
    let reference = spread.reference;
    let mut window_shift: Vec<WindowShift> = spread
        .used
        .iter()
        .map(|&i| WindowShift {
            name: BALANCE_NAMES[i],
            noise: spread.noise[i],
            shift: spread.shift[i],
            encoder: spread.encoder[i],
        })
        .collect();
    let (ei_noise, ei_shift, ei_encoder) = match reference {
        Reference::TipMass => (beam.ln_ei_std_err, beam.ln_ei_shift, beam.ln_ei_encoder),
        _ => (beam.std_err[0], beam.shift[0], beam.encoder[0]),
    };
    let mut beam_shift = |name, unit: f64, noise: f64, shift: f64, encoder: f64| {
        window_shift.push(WindowShift {
            name,
            noise: noise * unit,
            shift: shift * unit,
            encoder: encoder * unit,
        })
    };
    let slot = |i: usize| (beam.std_err[i], beam.shift[i], beam.encoder[i]);
    beam_shift("ei_nm2", p.ei_nm2, ei_noise, ei_shift, ei_encoder);
    if reference == Reference::TipMass {
        let (n, s, e) = slot(4);
        beam_shift("density_kg_m3", p.density_kg_m3, n, s, e);
    }
    let (n, s, e) = slot(1);
    beam_shift("damping_ratio", p.damping_ratio, n, s, e);
    if options.fit_gauge_position {
        let (n, s, e) = slot(2);
        beam_shift("root_gauge_m", 1.0, n, s, e);
    }
    let (n, s, e) = slot(3);
    beam_shift("gauge_scale", 1.0, n, s, e);
    window_shift
}

/// The one-sigma intervals of everything found.
fn uncertainties(
    spread: &BalanceSpread,
    beam: &BeamFit,
    found: &BeamParams,
    sensors: &Sensors,
    options: &SplitOptions,
    offset_fitted: bool,
) -> Vec<Uncertainty> {
    let (reference, sd) = (spread.reference, &spread.sd);
    let mut uncertainty = vec![];
    let mut add = |name: &'static str, value: f64, std_err: f64| {
        uncertainty.push(Uncertainty {
            name,
            value,
            std_err,
        })
    };
    // With the tip mass as the reference, step 1's density sets the level of everything
    // the balance scales with it (the scaling of tests/physics.rs): its relative error
    // adds in quadrature to theirs (the two steps fit different signals).
    // Step 1's errors: the noise's, the hub's smoothing's and the encoder's, in quadrature.
    let bsd = |slot: usize| {
        beam.std_err[slot]
            .hypot(beam.shift[slot])
            .hypot(beam.encoder[slot])
    };
    let rel_level = bsd(4);
    let level = |sd: f64, value: f64| (sd * sd + (rel_level * value).powi(2)).sqrt();
    add("jm_kgm2", found.jm_kgm2, level(sd[0], found.jm_kgm2));
    match reference {
        Reference::Torque => add("density_kg_m3", found.density_kg_m3, sd[1]),
        Reference::Density(_) => {}
        Reference::TipMass => add(
            "density_kg_m3",
            found.density_kg_m3,
            rel_level * found.density_kg_m3,
        ),
    }
    // EI = ratio x density: with the torque as the reference the density comes from step
    // 2, on another signal, and the relative errors add in quadrature; otherwise step 1
    // gives both (and with a known density, the ratio's error alone).
    let rel_ei = match reference {
        Reference::Torque => (bsd(0).powi(2) + (sd[1] / found.density_kg_m3).powi(2)).sqrt(),
        _ => beam
            .ln_ei_std_err
            .hypot(beam.ln_ei_shift)
            .hypot(beam.ln_ei_encoder),
    };
    add("ei_nm2", found.ei_nm2, rel_ei * found.ei_nm2);
    add(
        "viscous_nms",
        found.viscous_nms,
        level(sd[2], found.viscous_nms),
    );
    add(
        "coulomb_nm",
        found.coulomb_nm,
        level(sd[3], found.coulomb_nm),
    );
    if reference.measures_scale() {
        add(
            "torque_scale",
            sensors.torque_scale,
            level(sd[4], sensors.torque_scale),
        );
    }
    if offset_fitted {
        add("torque_offset_nm", sensors.torque_offset_nm, sd[5]);
    }
    add(
        "damping_ratio",
        found.damping_ratio,
        bsd(1) * found.damping_ratio,
    );
    if options.fit_gauge_position {
        add("root_gauge_m", found.root_gauge_m, bsd(2));
    }
    add("gauge_scale", sensors.gauge_scale, bsd(3));
    uncertainty
}

/// Pairs of results that correlate beyond [`TRADEOFF_CORRELATION`]: step 1's by its
/// Gauss-Newton covariance, the balance's by the bootstrap.
///
/// [`TRADEOFF_CORRELATION`]: crate::identify::calibrate::TRADEOFF_CORRELATION
fn tradeoffs(spread: &BalanceSpread, beam: &BeamFit) -> Vec<Tradeoff> {
    let mut tradeoffs = vec![];
    let beam_names = [
        "ei_over_density",
        "damping_ratio",
        "root_gauge_m",
        "gauge_scale",
        "density_kg_m3",
    ];
    for a in 0..5 {
        for b in a + 1..5 {
            let c = beam.corr[a][b];
            if c.abs() > crate::identify::calibrate::TRADEOFF_CORRELATION {
                tradeoffs.push(Tradeoff {
                    a: beam_names[a],
                    b: beam_names[b],
                    correlation: c,
                });
            }
        }
    }
    let used = &spread.used;
    for (ia, &a) in used.iter().enumerate() {
        for &b in &used[ia + 1..] {
            let c = correlation(&spread.boot, a, b);
            if c.abs() > crate::identify::calibrate::TRADEOFF_CORRELATION {
                tradeoffs.push(Tradeoff {
                    a: BALANCE_NAMES[a],
                    b: BALANCE_NAMES[b],
                    correlation: c,
                });
            }
        }
    }
    tradeoffs
}

/// The figures that check the result: the balance's residual, and the open-loop replay.
struct CheckFigures {
    balance_rms_err_nm: f64,
    balance_rms_torque_nm: f64,
    replay_rms_theta_err_rad: f64,
    move_span_rad: f64,
}

fn check_figures<const N: usize>(
    exps: &[Experiment],
    balance: &Balance,
    found: &BeamParams,
    sensors: &Sensors,
) -> Result<CheckFigures, CalibrateError> {
    let (mut se, mut sy) = (0.0, 0.0);
    for r in &balance.rows {
        let fit: f64 = r.x.iter().zip(&balance.coef).map(|(x, c)| x * c).sum();
        se += (r.y - fit).powi(2);
        sy += r.y * r.y;
    }
    let nr = balance.rows.len().max(1) as f64;
    let (mut th_se, mut th_n, mut span) = (0.0, 0usize, 0.0f64);
    for e in exps {
        let (lo, hi) = (0..e.log.t.len())
            .filter(|&k| in_window(e, k))
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), k| {
                (lo.min(e.log.theta[k]), hi.max(e.log.theta[k]))
            });
        if hi > lo {
            span = span.max(hi - lo);
        }
        let log = corrected(&e.log, sensors);
        let (th, _) = replay::<N>(&e.params(found), &log, e.windows.settle_end_s)
            .ok_or(CalibrateError::Breakdown { step: "rigid" })?;
        for (k, th) in th.iter().enumerate() {
            if in_window(e, k) {
                th_se += (th - log.theta[k]).powi(2);
                th_n += 1;
            }
        }
    }
    Ok(CheckFigures {
        balance_rms_err_nm: (se / nr).sqrt(),
        balance_rms_torque_nm: (sy / nr).sqrt(),
        replay_rms_theta_err_rad: (th_se / th_n.max(1) as f64).sqrt(),
        move_span_rad: span,
    })
}

/// Step 1: EI (at `g`'s density), damping, the gauge's position (if asked) and, with the
/// tip mass as the reference, the density (EI moving with it, at the ratio) by search; the
/// gauge's scale in closed form; on every log's move and settling. Then Levenberg-Marquardt
/// from the search's result, the Gauss-Newton intervals, and the shifts with the hub.
fn fit_beam<const N: usize>(
    exps: &[Experiment],
    hubs: &[HubMotion],
    alt_hubs: &[Vec<HubMotion>],
    enc_hubs: &[Vec<HubMotion>],
    g: &BeamParams,
    options: &SplitOptions,
) -> Result<BeamFit, CalibrateError> {
    let search = BeamSearch::new(exps, g, options);
    let dims = search.kinds.len();
    let u = minimise(
        dims,
        search.start(),
        options.evals,
        0x5B17 ^ dims as u64,
        BEAM_SEARCH_XTOL,
        &|u: &[f64]| search.cost::<N>(u, hubs),
    );
    let (params, lag_s, jac) = search.polish::<N>(search.at(&u), hubs)?;
    let n = jac.model.len();
    let rms_err = (rss(&jac.model, &jac.measured, jac.scale) / n as f64).sqrt();
    let (std_err, corr, ln_ei_std_err) = search.intervals(&jac);
    let scale = jac.scale;
    // The model's error as the fit's sensitivity to the hub: the fit polished again from
    // the result on the strain of the beam driven by another hub (one Gauss-Newton step
    // from the same Jacobian saw about half of the encoder's shift: it moves EI and the
    // damping together). Each shift by slot, and ln EI's.
    let shift_on = |hub: &[HubMotion]| -> Result<([f64; 5], f64), CalibrateError> {
        let (q, _, q_jac) = search.polish::<N>(params, hub)?;
        Ok((
            [
                (q.ei_nm2 / q.density_kg_m3).ln() - (params.ei_nm2 / params.density_kg_m3).ln(),
                (q.damping_ratio / params.damping_ratio).ln(),
                q.root_gauge_m - params.root_gauge_m,
                q_jac.scale - scale,
                (q.density_kg_m3 / params.density_kg_m3).ln(),
            ],
            (q.ei_nm2 / params.ei_nm2).ln(),
        ))
    };
    // Each view's polish is independent of the others': run them side by side (with the
    // hub smoothed twice and quantised at eight phases, they are most of the step's time).
    let shifts: Vec<([f64; 5], f64)> = alt_hubs
        .par_iter()
        .chain(enc_hubs.par_iter())
        .map(|hub| shift_on(hub))
        .collect::<Result<_, _>>()?;
    let (alt_shifts, enc_shifts) = shifts.split_at(alt_hubs.len());
    // The hub smoothed differently: the larger shift.
    let (mut shift, mut ln_ei_shift) = ([0.0f64; 5], 0.0f64);
    for &(d, ln_ei) in alt_shifts {
        for (s, d) in shift.iter_mut().zip(d) {
            *s = s.max(d.abs());
        }
        ln_ei_shift = ln_ei_shift.max(ln_ei.abs());
    }
    // The angle re-quantised: the RMS shift.
    let (mut encoder, mut ln_ei_encoder) = ([0.0f64; 5], 0.0f64);
    for &(d, ln_ei) in enc_shifts {
        for (s, d) in encoder.iter_mut().zip(d) {
            *s += d * d / enc_hubs.len() as f64;
        }
        ln_ei_encoder += ln_ei * ln_ei / enc_hubs.len() as f64;
    }
    let (encoder, ln_ei_encoder) = (encoder.map(f64::sqrt), ln_ei_encoder.sqrt());
    let at_bound = search.at_bound(&params);
    Ok(BeamFit {
        params,
        gauge_scale: scale,
        rms_err,
        lag_s,
        std_err,
        corr,
        ln_ei_std_err,
        shift,
        ln_ei_shift,
        encoder,
        ln_ei_encoder,
        at_bound,
    })
}

/// Step 1's search: the coordinates it moves, from the starting parameters.
struct BeamSearch<'a> {
    exps: &'a [Experiment],
    g: &'a BeamParams,
    /// Fit the sensor's lag in the polish ([`SplitOptions::fit_lag`]).
    fit_lag: bool,
    /// The searched coordinates, by slot: 0 EI at the density, 1 damping, 2 the gauge's
    /// position, 4 the density and EI together (3, the gauge's scale, is closed form).
    kinds: Vec<usize>,
}

/// The model's strain and the measured one (ue) over every log's window, the gauge's best
/// scale, and the columns d(scale x model)/d(coordinates), the model itself last (for the
/// scale).
struct Jacobian {
    model: Vec<f64>,
    measured: Vec<f64>,
    scale: f64,
    cols: Vec<Vec<f64>>,
}

/// With the best gauge scale s = pm/pp the residual is mm - pm^2/pp.
fn sums(m: &[f64], y: &[f64]) -> (f64, f64, f64) {
    m.iter()
        .zip(y)
        .fold((0.0, 0.0, 0.0), |(pm, pp, mm), (a, b)| {
            (pm + a * b, pp + a * a, mm + b * b)
        })
}

/// The residual sum of squares with the gauge's scale `scale`.
fn rss(m: &[f64], y: &[f64], scale: f64) -> f64 {
    m.iter().zip(y).map(|(m, y)| (y - scale * m).powi(2)).sum()
}

impl<'a> BeamSearch<'a> {
    fn new(exps: &'a [Experiment], g: &'a BeamParams, options: &SplitOptions) -> Self {
        let mut kinds = vec![0usize, 1];
        if options.fit_gauge_position {
            kinds.push(2);
        }
        if options.reference == Reference::TipMass {
            kinds.push(4);
        }
        Self {
            exps,
            g,
            kinds,
            fit_lag: options.fit_lag,
        }
    }

    /// The search's range of a coordinate.
    fn range(&self, kind: usize) -> Param {
        let g = self.g;
        match kind {
            0 => Param {
                name: "ei_nm2",
                lo: g.ei_nm2 / 2.0,
                hi: g.ei_nm2 * 2.0,
                log: true,
            },
            1 => Param {
                name: "damping_ratio",
                lo: 1e-3,
                hi: 0.2,
                log: true,
            },
            2 => Param {
                name: "root_gauge_m",
                lo: 0.0,
                hi: 0.2 * g.length_m,
                log: false,
            },
            _ => Param {
                name: "density_kg_m3",
                lo: g.density_kg_m3 / 3.0,
                hi: g.density_kg_m3 * 3.0,
                log: true,
            },
        }
    }

    /// The searched coordinates of `p` that sit on a bound of their range (after the
    /// polish, which may also have left it).
    fn at_bound(&self, p: &BeamParams) -> Vec<AtBound> {
        self.kinds
            .iter()
            .filter_map(|&kind| {
                let v = match kind {
                    // The search's EI is at the guess's density.
                    0 => p.ei_nm2 * self.g.density_kg_m3 / p.density_kg_m3,
                    1 => p.damping_ratio,
                    2 => p.root_gauge_m,
                    _ => p.density_kg_m3,
                };
                AtBound::check(&self.range(kind), v)
            })
            .collect()
    }

    /// The starting point in the search's unit coordinates.
    fn start(&self) -> Vec<f64> {
        let g = self.g;
        self.kinds
            .iter()
            .map(|&kind| {
                self.range(kind).unit_of(match kind {
                    0 => g.ei_nm2,
                    1 => g.damping_ratio.max(1e-3),
                    2 => g.root_gauge_m,
                    _ => g.density_kg_m3,
                })
            })
            .collect()
    }

    /// The parameters at unit coordinates `u`.
    fn at(&self, u: &[f64]) -> BeamParams {
        let mut p = *self.g;
        for (&kind, &x) in self.kinds.iter().zip(u) {
            let v = self.range(kind).gain_at(x);
            match kind {
                0 => p.ei_nm2 = v,
                1 => p.damping_ratio = v,
                2 => p.root_gauge_m = v,
                _ => p.density_kg_m3 = v,
            }
        }
        // The density moves EI with it: the search's EI is at the guess's density.
        p.ei_nm2 *= p.density_kg_m3 / self.g.density_kg_m3;
        p
    }

    /// Model and measured beam signal (in its display unit, [`BeamSensor::unit`]) over
    /// every log's window, the beam driven by `hubs`, the model's read `lag_s` late.
    fn strains<const N: usize>(
        &self,
        p: &BeamParams,
        hubs: &[HubMotion],
        lag_s: f64,
    ) -> Option<(Vec<f64>, Vec<f64>)> {
        Some(self.windowed(&self.series::<N>(p, hubs)?, lag_s))
    }

    /// Each log's beam signal (SI) over the whole log, the beam of `p` (with the log's tip
    /// mass) driven by `hubs`: one model built for the logs that share a tip mass.
    fn series<const N: usize>(&self, p: &BeamParams, hubs: &[HubMotion]) -> Option<Vec<Vec<f64>>> {
        let mut built: Option<(BeamParams, Plant<N>)> = None;
        let mut out = Vec::with_capacity(self.exps.len());
        for (e, hub) in self.exps.iter().zip(hubs) {
            let q = e.params(p);
            let plant = match &built {
                Some((b, plant)) if *b == q => plant,
                _ => &built.insert((q, beam_plant::<N>(&q)?)).1,
            };
            out.push(prescribed_on(plant, &e.log, hub, None)?.beam_signal);
        }
        Some(out)
    }

    /// [`Self::series`] read `lag_s` late, and the measured signal, over every log's
    /// window, in the signal's display unit.
    fn windowed(&self, series: &[Vec<f64>], lag_s: f64) -> (Vec<f64>, Vec<f64>) {
        let (mut model, mut measured) = (vec![], vec![]);
        for (e, eps) in self.exps.iter().zip(series) {
            let unit = e.log.sensor.display_scale();
            let late = lagged(eps, lag_s / (e.log.t[1] - e.log.t[0]));
            for (k, m) in late.iter().enumerate() {
                if in_window(e, k) {
                    model.push(m * unit);
                    measured.push(e.log.beam_signal[k] * unit);
                }
            }
        }
        (model, measured)
    }

    /// The search's cost at `u`: the log of the mean squared residual at the best scale.
    fn cost<const N: usize>(&self, u: &[f64], hubs: &[HubMotion]) -> f64 {
        match self.strains::<N>(&self.at(u), hubs, 0.0) {
            Some((m, y)) if !m.is_empty() => {
                let (pm, pp, mm) = sums(&m, &y);
                if pp > 0.0 {
                    ((mm - pm * pm / pp).max(0.0) / m.len() as f64 + 1e-12).ln()
                } else {
                    1e3
                }
            }
            _ => 1e3,
        }
    }

    /// A step of `d` in the Gauss-Newton coordinates (ln EI/rho, ln zeta, gauge, ln rho at
    /// the ratio) from `q`.
    fn step(q: &BeamParams, kind: usize, d: f64) -> BeamParams {
        let mut q = *q;
        match kind {
            0 => q.ei_nm2 *= d.exp(),
            1 => q.damping_ratio *= d.exp(),
            2 => q.root_gauge_m = (q.root_gauge_m + d).max(0.0),
            _ => {
                q.ei_nm2 *= d.exp();
                q.density_kg_m3 *= d.exp();
            }
        }
        q
    }

    /// At `q`: the model's strain, the measured, the gauge's scale and the columns by
    /// central differences. (At the gauge's lower bound the difference is one-sided: the
    /// step down is clamped.)
    fn jacobian<const N: usize>(
        &self,
        q: &BeamParams,
        hubs: &[HubMotion],
        lag_s: f64,
        lag_column: bool,
    ) -> Result<Jacobian, CalibrateError> {
        let breakdown = || CalibrateError::Breakdown { step: "beam" };
        let series = self.series::<N>(q, hubs).ok_or_else(breakdown)?;
        let (m0, y) = self.windowed(&series, lag_s);
        let (pm, pp, _) = sums(&m0, &y);
        if !(pp > 0.0) {
            return Err(breakdown());
        }
        let scale = pm / pp;
        let mut cols: Vec<Vec<f64>> = vec![];
        for &kind in &self.kinds {
            let h = if kind == 2 { 1e-4 } else { 1e-3 };
            let (qu, qd) = (Self::step(q, kind, h), Self::step(q, kind, -h));
            let dh = match kind {
                2 => qu.root_gauge_m - qd.root_gauge_m,
                _ => 2.0 * h,
            };
            let (Some((up, _)), Some((down, _))) = (
                self.strains::<N>(&qu, hubs, lag_s),
                self.strains::<N>(&qd, hubs, lag_s),
            ) else {
                return Err(breakdown());
            };
            cols.push(
                up.iter()
                    .zip(&down)
                    .map(|(a, b)| scale * (a - b) / dh)
                    .collect(),
            );
        }
        // The lag's column (in ms, so that its step is of the others' size), when fitted:
        // between the coordinates' and the model's own.
        if lag_column {
            let h = 0.25 * (self.exps[0].log.t[1] - self.exps[0].log.t[0]);
            let ((up, _), (down, _)) = (
                self.windowed(&series, lag_s + h),
                self.windowed(&series, lag_s - h),
            );
            cols.push(
                up.iter()
                    .zip(&down)
                    .map(|(a, b)| scale * (a - b) / (2.0 * h * 1e3))
                    .collect(),
            );
        }
        cols.push(m0.clone());
        Ok(Jacobian {
            model: m0,
            measured: y,
            scale,
            cols,
        })
    }

    /// Levenberg-Marquardt from `params` on `hubs`: the search stops short in a long valley
    /// (a tip mass's density against EI/rho correlate at -0.9999 on a smooth move), and the
    /// standard errors hold only at the minimum.
    ///
    /// With [`SplitOptions::fit_lag`], the sensor's lag beyond the logs' is a coordinate of
    /// the polish too (from none, within +-[`MAX_STRAIN_DELAY_S`]), kept if it is more than
    /// a sample and a half (else polished again without it); the returned Jacobian, whose
    /// columns give the intervals, is at the fitted lag without the lag's column (the
    /// intervals hold the lag as found).
    fn polish<const N: usize>(
        &self,
        mut params: BeamParams,
        hubs: &[HubMotion],
    ) -> Result<(BeamParams, f64, Jacobian), CalibrateError> {
        let mut lag = self.fit_lag.then_some(0.0);
        let mut jac = self.jacobian::<N>(&params, hubs, 0.0, self.fit_lag)?;
        let mut lambda = 1e-3;
        for _ in 0..POLISH_ITERATIONS {
            let Jacobian {
                model: m0,
                measured: y,
                scale,
                cols,
            } = &jac;
            let k = cols.len();
            let resid: Vec<f64> = m0.iter().zip(y).map(|(m, y)| y - scale * m).collect();
            let mut a = vec![vec![0.0; k]; k];
            let mut g = vec![0.0; k];
            for i in 0..k {
                for j in 0..k {
                    a[i][j] = cols[i].iter().zip(&cols[j]).map(|(p, q)| p * q).sum();
                }
                g[i] = cols[i].iter().zip(&resid).map(|(p, r)| p * r).sum();
            }
            let before = rss(m0, y, *scale);
            let mut improved = false;
            while lambda < 1e6 {
                let mut damped = a.clone();
                for (i, row) in damped.iter_mut().enumerate() {
                    row[i] += lambda * a[i][i];
                }
                let Some(d) = crate::identify::lsq::solve(damped, g.clone()) else {
                    lambda *= 10.0;
                    continue;
                };
                let mut q = params;
                for (&kind, &d) in self.kinds.iter().zip(&d) {
                    q = Self::step(&q, kind, d.clamp(-0.3, 0.3));
                }
                // The lag's step is in ms, after the coordinates'.
                let lag_q = lag.map(|l| {
                    (l + 1e-3 * d[self.kinds.len()].clamp(-5.0, 5.0))
                        .clamp(-MAX_STRAIN_DELAY_S, MAX_STRAIN_DELAY_S)
                });
                if Beam::try_build(q).is_ok() {
                    if let Some((m, yy)) = self.strains::<N>(&q, hubs, lag_q.unwrap_or(0.0)) {
                        let (pm, pp, _) = sums(&m, &yy);
                        if pp > 0.0 && rss(&m, &yy, pm / pp) < before {
                            params = q;
                            lag = lag_q;
                            improved = true;
                            lambda = (lambda / 10.0).max(1e-6);
                            break;
                        }
                    }
                }
                lambda *= 10.0;
            }
            if !improved {
                break;
            }
            jac = self.jacobian::<N>(&params, hubs, lag.unwrap_or(0.0), self.fit_lag)?;
            let after = rss(&jac.model, &jac.measured, jac.scale);
            if before - after < 1e-6 * before {
                break;
            }
        }
        let lag_s = lag.unwrap_or(0.0);
        if lag.is_some() {
            // A lag within a sample and a half is not told from the model's own phase
            // error (on a log with none it came out -0.7 ms at 1 kHz, and the damping took
            // it, 0.0146 against 0.0116 held): the beam again with the lag held at none.
            let dt = self.exps[0].log.t[1] - self.exps[0].log.t[0];
            if lag_s.abs() < 1.5 * dt {
                let held = BeamSearch {
                    exps: self.exps,
                    g: self.g,
                    kinds: self.kinds.clone(),
                    fit_lag: false,
                };
                return held.polish::<N>(params, hubs);
            }
            jac = self.jacobian::<N>(&params, hubs, lag_s, false)?;
        }
        Ok((params, lag_s, jac))
    }

    /// Gauss-Newton standard errors and correlations at the fit, by slot (zero where held),
    /// inflated for the residuals' autocorrelation; and ln EI's (ln EI/rho plus ln rho).
    fn intervals(&self, jac: &Jacobian) -> ([f64; 5], [[f64; 5]; 5], f64) {
        let (m0, y, scale, cols) = (&jac.model, &jac.measured, jac.scale, &jac.cols);
        let n = m0.len();
        let mut slots = self.kinds.clone();
        slots.push(3);
        let resid: Vec<f64> = m0.iter().zip(y).map(|(m, y)| y - scale * m).collect();
        let k = cols.len();
        let mut normal = Normal::new(k);
        for i in 0..n {
            let x: Vec<f64> = cols.iter().map(|c| c[i]).collect();
            normal.add(&x, resid[i]);
        }
        let inv = normal.solve().map(|f| f.xtx_inv);
        let s2 = resid.iter().map(|r| r * r).sum::<f64>() / (n.saturating_sub(k)).max(1) as f64;
        let inflation = autocorrelation_inflation(&resid);
        let (mut std_err, mut corr, mut cov) = ([0.0; 5], [[0.0; 5]; 5], [[0.0; 5]; 5]);
        let mut ln_ei_std_err = f64::INFINITY;
        match inv {
            Some(inv) => {
                for i in 0..k {
                    std_err[slots[i]] = (s2 * inflation * inv[i][i]).max(0.0).sqrt();
                    for j in 0..k {
                        corr[slots[i]][slots[j]] = inv[i][j] / (inv[i][i] * inv[j][j]).sqrt();
                        cov[slots[i]][slots[j]] = s2 * inflation * inv[i][j];
                    }
                }
                // ln EI = ln EI/rho + ln rho.
                ln_ei_std_err = (cov[0][0] + cov[4][4] + 2.0 * cov[0][4]).max(0.0).sqrt();
            }
            None => std_err = [f64::INFINITY; 5],
        }
        (std_err, corr, ln_ei_std_err)
    }
}

/// `(1 + r) / (1 - r)` for the residuals' lag-one autocorrelation `r` (clamped to
/// 0..0.99): how many logged samples make one independent one, for an AR(1) residual.
fn autocorrelation_inflation(r: &[f64]) -> f64 {
    let var: f64 = r.iter().map(|x| x * x).sum();
    if var <= 0.0 || r.len() < 3 {
        return 1.0;
    }
    let lag: f64 = r.windows(2).map(|w| w[0] * w[1]).sum();
    let rho = (lag / var).clamp(0.0, 0.99);
    (1.0 + rho) / (1.0 - rho)
}

/// Levenberg-Marquardt iterations after step 1's search, at most.
const POLISH_ITERATIONS: usize = 8;

/// Length of the intervals the torque balance is integrated over, s. (On the other-rig
/// log over eight noise draws: at 20 ms the rates' noise biased Jm by -28 %; 50 ms and
/// 100 ms gave -1.8 % and +2.8 %.)
pub const BALANCE_INTERVAL_S: f64 = 0.05;

/// Half-width of the quadratic fit that gives the balance its hub rates, s (at least two
/// samples). (The same draws: 5 ms gave Jm -1.8 +- 1.7 % and a torque scale 0.3 % off;
/// 15 ms, the prescribed beam's window there, +3.4 % and 0.8 % off, outside the
/// intervals for viscous friction in seven draws of eight.)
pub const BALANCE_RATE_WINDOW_S: f64 = 0.005;

/// The torque balance's rows over every log's move and settling, hub moving throughout the
/// interval, at `p`; and whether the logs move both ways enough to fit an offset. Each row
/// is the balance integrated over [`BALANCE_INTERVAL_S`] from a sample (intervals overlap):
/// the logged torque's integral (exact for a torque held over each sample) against the
/// change of the hub's rate (from `rates`), the beam's torque R (its rigid inertia times
/// the same change, plus the integral of its flexing's part from the beam driven by
/// `hubs`, as in step 1), the change of angle, the integral of sgn(omega) (the plant's
/// smoothed sign) and the interval's length. Integrated, the encoder's steps enter through
/// two rate estimates a row instead of an acceleration at every sample, whose noise would
/// bias Jm (errors in the regressor); and the flexing comes from the smooth hub that fits
/// the strain, not from the encoder's steps.
fn balance_rows<const N: usize>(
    exps: &[Experiment],
    hubs: &[HubMotion],
    rates: &[HubMotion],
    p: &BeamParams,
    observers: &[StrainObserver],
) -> Result<(Vec<Row>, bool), CalibrateError> {
    let mut rows = vec![];
    let (mut up, mut down) = (0usize, 0usize);
    for (((e, hub), rate), obs) in exps.iter().zip(hubs).zip(rates).zip(observers) {
        let pr = prescribed_observed::<N>(&e.params(p), &e.log, hub, Some(*obs))
            .ok_or(CalibrateError::Breakdown { step: "rigid" })?;
        let dt = e.log.t[1] - e.log.t[0];
        let w = ((BALANCE_INTERVAL_S / dt).round() as usize).max(2);
        let omega = &rate.omega;
        let peak = omega.iter().fold(0.0f64, |a, w| a.max(w.abs()));
        let moving: Vec<bool> = (0..e.log.t.len())
            .map(|k| in_window(e, k) && omega[k].abs() > MOVING_FRACTION * peak)
            .collect();
        let sgn: Vec<f64> = omega
            .iter()
            .map(|w| (w / COULOMB_SMOOTHING_RAD_S).tanh())
            .collect();
        let trapezoid = |v: &[f64], k: usize| -> f64 {
            dt * (0.5 * v[k] + v[k + 1..k + w].iter().sum::<f64>() + 0.5 * v[k + w])
        };
        // An interval counts when the hub moves throughout it, one way, and covers at least
        // half the angle the threshold rate would: an encoder dithering by a count at rest
        // (a PD hub parked on a count's edge) shows rates of a few percent of a slow move's
        // peak, both ways, but no net angle.
        let min_angle = 0.5 * MOVING_FRACTION * peak * w as f64 * dt;
        for k in 0..e.log.t.len().saturating_sub(w) {
            let one_way = omega[k..=k + w]
                .iter()
                .all(|x| x.signum() == omega[k].signum());
            let angle = e.log.theta[k + w] - e.log.theta[k];
            if !moving[k..=k + w].iter().all(|&m| m)
                || !one_way
                || angle.abs() < min_angle
                || angle.signum() != omega[k].signum()
            {
                continue;
            }
            if omega[k] > 0.0 {
                up += 1;
            } else {
                down += 1;
            }
            let d_omega = omega[k + w] - omega[k];
            rows.push(Row {
                x: [
                    d_omega,
                    pr.beam_inertia_kgm2 * d_omega + trapezoid(&pr.flex_torque_nm, k),
                    angle,
                    trapezoid(&sgn, k),
                    w as f64 * dt,
                ],
                y: dt * e.log.torque[k..k + w].iter().sum::<f64>(),
            });
        }
    }
    if rows.len() < 20 {
        return Err(CalibrateError::TooLittleMotion(rows.len()));
    }
    let both = up.min(down) as f64 >= BOTH_WAYS_FRACTION * (up + down) as f64;
    Ok((rows, both))
}

/// Least squares of the balance; the offset column dropped (coefficient 0) unless `offset`.
fn fit_balance(rows: &[Row], offset: bool) -> Result<[f64; 5], CalibrateError> {
    let cols = if offset { 5 } else { 4 };
    let mut n = Normal::new(cols);
    for r in rows {
        n.add(&r.x[..cols], r.y);
    }
    let f = n
        .solve()
        .ok_or(CalibrateError::TooLittleMotion(rows.len()))?;
    Ok(core::array::from_fn(|i| {
        f.coef.get(i).copied().unwrap_or(0.0)
    }))
}

/// The balance refitted on [`BOOTSTRAP`] moving-block resamples of its rows (blocks of
/// `block_s` at the first log's rate); resamples whose fit is singular are skipped.
fn bootstrap(rows: &[Row], exps: &[Experiment], offset: bool, block_s: f64) -> Vec<[f64; 5]> {
    let dt = exps[0].log.t[1] - exps[0].log.t[0];
    let block = ((block_s / dt).round() as usize).clamp(1, rows.len());
    let starts = rows.len() - block + 1;
    let mut rng = StdRng::seed_from_u64(0xB007);
    let mut out = vec![];
    for _ in 0..BOOTSTRAP {
        let mut sample = Vec::with_capacity(rows.len());
        while sample.len() < rows.len() {
            let s = rng.gen_range(0..starts);
            sample.extend_from_slice(&rows[s..s + block]);
        }
        sample.truncate(rows.len());
        if let Ok(c) = fit_balance(&sample, offset) {
            out.push(c);
        }
    }
    out
}

/// The first lag, in rows, at which the autocorrelation of `r` falls below 1/e (at most half
/// its length).
fn decorrelation_lag(r: &[f64]) -> usize {
    let var: f64 = r.iter().map(|x| x * x).sum();
    if var <= 0.0 {
        return 1;
    }
    (1..r.len() / 2)
        .find(|&lag| {
            let c: f64 = r.iter().zip(&r[lag..]).map(|(a, b)| a * b).sum();
            c / var < (-1.0f64).exp()
        })
        .unwrap_or(r.len() / 2)
}

/// The correlation of columns `a` and `b` over the resamples.
fn correlation(samples: &[[f64; 6]], a: usize, b: usize) -> f64 {
    let n = samples.len() as f64;
    if n < 3.0 {
        return 0.0;
    }
    let (ma, mb) = (
        samples.iter().map(|s| s[a]).sum::<f64>() / n,
        samples.iter().map(|s| s[b]).sum::<f64>() / n,
    );
    let (mut sab, mut saa, mut sbb) = (0.0, 0.0, 0.0);
    for s in samples {
        sab += (s[a] - ma) * (s[b] - mb);
        saa += (s[a] - ma).powi(2);
        sbb += (s[b] - mb).powi(2);
    }
    if saa > 0.0 && sbb > 0.0 {
        sab / (saa * sbb).sqrt()
    } else {
        0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn logs_of_two_sensors_or_a_gauge_position_on_a_tip_log_are_refused() {
        // One fit pools the beam's residuals, which must share a unit; a tip log has no
        // root gauge whose position could be fitted.
        let t: Vec<f64> = (0..200).map(|k| k as f64 * 1e-3).collect();
        let log = |sensor| Log {
            torque: vec![0.0; t.len()],
            theta: t.iter().map(|x| (x * 5.0).sin()).collect(),
            beam_signal: vec![0.0; t.len()],
            sensor,
            mid_strain: None,
            t: t.clone(),
        };
        let exp = |sensor| {
            let l = log(sensor);
            let w = crate::identify::calibrate::Windows::given(0.0, 0.1, 0.19, &l).unwrap();
            Experiment::new(l, w)
        };
        let (gauge, tip) = (exp(BeamSensor::RootStrain), exp(BeamSensor::TipDeflection));
        assert!(matches!(
            one_sensor(&[gauge.clone(), tip.clone()]),
            Err(CalibrateError::MixedSensors(
                "root strain",
                "tip deflection"
            ))
        ));
        assert_eq!(
            one_sensor(&[tip.clone(), tip.clone()]).unwrap(),
            BeamSensor::TipDeflection
        );
        let options = SplitOptions {
            reference: Reference::Torque,
            fit_gauge_position: true,
            fit_offset: false,
            fit_lag: false,
            evals: 10,
            encoder_step_rad: None,
        };
        let refused = calibrate_split::<3>(&[tip], &model_core::BeamParams::aluminium(), &options);
        assert!(
            matches!(refused, Err(CalibrateError::SensorUnsupported(m)) if m.contains("gauge's position")),
            "{:?}",
            refused.map(|r| r.0)
        );
    }

    /// Balance rows made from a known rigid body and torque offset: intervals of 10 ms,
    /// alternating direction (or all one way), each accelerating the hub (so an offset left
    /// out is taken for inertia).
    fn rows(offset_nm: f64, both_ways: bool) -> Vec<Row> {
        let (jm, viscous, coulomb, t) = (0.007, 1e-4, 0.01, 0.01);
        (0..200)
            .map(|i| {
                let k = i as f64;
                let dir = if both_ways && i % 2 == 1 { -1.0 } else { 1.0 };
                let x = [
                    0.5 + 0.1 * k.sin(),
                    1e-3 * (0.7 * k).cos(),
                    dir * 0.01 * (1.0 + 0.3 * (1.3 * k).sin()),
                    dir * t,
                    t,
                ];
                let y = jm * x[0] + x[1] + viscous * x[2] + coulomb * x[3] + offset_nm * x[4];
                Row { x, y }
            })
            .collect()
    }

    fn balance(rows: Vec<Row>) -> Balance {
        let coef = fit_balance(&rows, false).unwrap();
        Balance {
            params: BeamParams::aluminium(),
            rows,
            coef,
            offset_fitted: false,
        }
    }

    #[test]
    fn an_offset_left_out_is_named_as_the_cause_when_it_makes_the_balance_physical() {
        let b = balance(rows(-0.5, true));
        // Left out, the offset's torque is taken for inertia: Jm comes out negative.
        let d = b.derived(&b.coef, Reference::Torque);
        assert!(!physical(&d), "{d:?}");
        match unphysical_cause(&b, Reference::Torque) {
            UnphysicalCause::Offset { offset_nm, jm } => {
                assert!((offset_nm + 0.5).abs() < 1e-6, "{offset_nm}");
                assert!((jm - 0.007).abs() < 1e-6, "{jm}");
            }
            other => panic!("{other:?}"),
        }
        // Moving one way an offset cannot be told from Coulomb friction: no cause claimed.
        let one_way = balance(rows(-0.5, false));
        assert_eq!(
            unphysical_cause(&one_way, Reference::Torque),
            UnphysicalCause::Unknown
        );
    }
}
