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

use crate::fit::{minimise, Param};
use crate::identify::calibrate::{
    lagged, replay, AtBound, BeamSensor, CalibrateError, Experiment, Log, Tradeoff, Uncertainty,
    UnphysicalCause, REST_BEFORE_S,
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

mod balance;
mod beam_fit;
mod spread;
use balance::*;
pub use balance::{BALANCE_INTERVAL_S, BALANCE_RATE_WINDOW_S};
use beam_fit::*;
use spread::*;

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

/// The balance's beam held at its density, the torque read true ([`SplitReport::beam_held`]).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct HeldBeam {
    /// The density held, kg/m^3.
    pub density_kg_m3: f64,
    /// What the free fit gave, if it ran to the end: Jm, density, torque scale.
    pub free: Option<(f64, f64, f64)>,
    /// Whether the density was the user's (`Reference::Density`): then it is the torque's
    /// scale that the logs could not give.
    pub density_given: bool,
}

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
    /// The free balance was not physical, so the beam's torque was held at its density
    /// with the torque read true, Jm and friction fitted with it. `None`: the free fit
    /// stood.
    pub beam_held: Option<HeldBeam>,
    /// The torque read at rest before the moves, taken out as its offset (and in
    /// `sensors`). `None`: no rest, or none to take out.
    pub rest_offset: Option<RestOffset>,
    /// Coulomb friction found to differ by direction (in the parameters found as
    /// `coulomb_asym_nm`). `None`: the same both ways, or not told.
    pub coulomb_asym: Option<DirectionalFriction>,
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
    // A torque that reads other than zero at rest before every move is the torque's
    // offset: taken out here, put back into the sensors found.
    let level = rest_level(exps);
    let rest = level.filter(significant);
    let shifted: Vec<Experiment>;
    let exps = match rest {
        Some(o) => {
            shifted = exps
                .iter()
                .map(|e| {
                    let mut e = e.clone();
                    e.log.torque.iter_mut().for_each(|u| *u -= o.offset_nm);
                    e
                })
                .collect();
            &shifted[..]
        }
        None => exps,
    };
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
    let with_offset = SplitOptions {
        fit_offset: true,
        ..*options
    };
    // With the torque's zero read at rest, a torque left the same way in both directions
    // of motion is not an offset: it is Coulomb friction that differs by direction (it acts
    // only while the hub turns). The balance is fitted with it wherever the logs move both
    // ways, and it is kept when it is within what friction can be (no more than the mean
    // Coulomb friction either way) and told: [`UNPLACED_SIGMAS`] of its error from zero, or
    // the open-loop hub of the logs' torque drifts [`UNPLACED_RMS_RATIO`] as far or less
    // with it. (On the second rig's stand-in, 8 mN m of a 20 mN m friction had an error of
    // 11 mN m from the balance's bootstrap, but took the open-loop drift from 4.8 deg to
    // 0.24 deg.)
    let directional = match (level, options.fit_offset) {
        (Some(_), false) => rigid_body::<N>(&inputs, &views, &beam, &with_offset)
            .ok()
            .and_then(|(mut found, mut sensors, mut report)| {
                let asym = sensors.torque_offset_nm / sensors.torque_scale;
                let u = report
                    .uncertainty
                    .iter_mut()
                    .find(|u| u.name == "torque_offset_nm")?;
                let std_err = u.std_err / sensors.torque_scale;
                // Told by its error, or by the hub it predicts: the logged torque, replayed
                // open loop, drifts from the logged angle half as far or less with it.
                let told = asym.abs() > UNPLACED_SIGMAS * std_err
                    || report.replay_rms_theta_err_rad
                        <= UNPLACED_RMS_RATIO * first.2.replay_rms_theta_err_rad;
                if !told || asym.abs() > found.coulomb_nm {
                    return None;
                }
                (u.name, u.value, u.std_err) = ("coulomb_asym_nm", asym, std_err);
                found.coulomb_asym_nm = asym;
                sensors.torque_offset_nm = 0.0;
                report.sensors = sensors;
                report.offset_fitted = false;
                report.unplaced_offset = None;
                report.coulomb_asym = Some(DirectionalFriction {
                    asym_nm: asym,
                    std_err_nm: std_err,
                    rms_err_without_nm: first.2.balance_rms_err_nm,
                    rms_err_with_nm: report.balance_rms_err_nm,
                });
                Some((found, sensors, report))
            }),
        _ => None,
    };
    // Else a torque the balance could not place in either direction ([`unplaced_offset`]):
    // the rigid body again with an offset (step 1, the beam, does not depend on it), and
    // said.
    let (found, mut sensors, mut report) = match (directional, first.2.unplaced_offset) {
        (Some(d), _) => d,
        (None, Some(u)) => {
            let (found, sensors, mut report) =
                rigid_body::<N>(&inputs, &views, &beam, &with_offset)?;
            report.unplaced_offset = Some(u);
            (found, sensors, report)
        }
        (None, None) => first,
    };
    if let Some(o) = rest {
        sensors.torque_offset_nm += o.offset_nm;
        report.sensors = sensors;
        report.rest_offset = Some(o);
    }
    Ok((found, sensors, report))
}

/// The torque's reading at rest before the moves ([`rest_offset`]).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct RestOffset {
    /// The torque read at rest, N m (the median over every log's rest).
    pub offset_nm: f64,
    /// Its one-sigma error, N m (the rests' spread over the root of their length).
    pub std_err_nm: f64,
}

/// How many of its errors the torque at rest must be from zero to be taken as an offset.
pub const REST_OFFSET_SIGMAS: f64 = 4.0;

/// The torque every log reads at rest before its first move, when each has at least
/// [`REST_BEFORE_S`] of it (to 20 ms before the move's start), they agree within three
/// combined errors, and it is [`REST_OFFSET_SIGMAS`] of its error from zero: the hub held
/// still on its first angle by a controller with nothing to correct takes no torque, so
/// what the torque reads there is its zero's offset (a torque derived from a motor's
/// voltage and speed carries one). The rests between the moves of a log cut into several
/// are not used: the hub stops where friction holds it, off its target, and the drive
/// holds it there with a torque anywhere within the friction. `None` otherwise: a log that
/// starts moving, or rests that disagree (a controller holding the hub against
/// something).
pub fn rest_offset(exps: &[Experiment]) -> Option<RestOffset> {
    rest_level(exps).filter(significant)
}

/// The level is [`REST_OFFSET_SIGMAS`] of its error from zero.
fn significant(o: &RestOffset) -> bool {
    o.offset_nm.abs() > REST_OFFSET_SIGMAS * o.std_err_nm
}

/// The torque every log reads at rest before its move, as [`rest_offset`] finds it, whether
/// or not it is far from zero: `Some` where the torque's zero is known.
fn rest_level(exps: &[Experiment]) -> Option<RestOffset> {
    let mut levels = vec![];
    for e in exps.iter().filter(|e| e.rest_is_start) {
        let t0 = e.log.t[0];
        let until = e.windows.start_s - 0.02;
        if e.windows.start_s < REST_BEFORE_S {
            return None;
        }
        let mut rest: Vec<f64> = e
            .log
            .t
            .iter()
            .zip(&e.log.torque)
            .filter(|(t, _)| **t - t0 <= until)
            .map(|(_, u)| *u)
            .collect();
        if rest.len() < 20 {
            return None;
        }
        rest.sort_by(f64::total_cmp);
        let median = rest[rest.len() / 2];
        let mut dev: Vec<f64> = rest.iter().map(|u| (u - median).abs()).collect();
        dev.sort_by(f64::total_cmp);
        // The spread (1.4826 MAD), over the root of the samples: the median's error, near
        // enough.
        let err = 1.4826 * dev[dev.len() / 2] / (rest.len() as f64).sqrt();
        levels.push((median, err.max(1e-12)));
    }
    let (first, first_err) = *levels.first()?;
    if levels
        .iter()
        .any(|(l, e)| (l - first).abs() > 3.0 * e.hypot(first_err))
    {
        return None;
    }
    let weight: f64 = levels.iter().map(|(_, e)| 1.0 / (e * e)).sum();
    let offset_nm = levels.iter().map(|(l, e)| l / (e * e)).sum::<f64>() / weight;
    let std_err_nm = weight.sqrt().recip();
    Some(RestOffset {
        offset_nm,
        std_err_nm,
    })
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
    // A balance the density's iteration found unphysical: a log cut inside a move is the
    // likelier cause than the general one, where it is so.
    let mut balance =
        solve_balance::<N>(inputs, &views.hubs, &beam.params, options).map_err(|e| {
            match (e, starts_moving(exps)) {
                (
                    CalibrateError::Unphysical {
                        jm,
                        density,
                        torque_scale,
                        cause: UnphysicalCause::Unknown,
                    },
                    Some((log, fraction)),
                ) => CalibrateError::Unphysical {
                    jm,
                    density,
                    torque_scale,
                    cause: UnphysicalCause::StartsMoving { log, fraction },
                },
                (e, _) => e,
            }
        })?;
    let mut d = balance.derived(&balance.coef, reference);
    let free = (!balance.beam_held).then_some(d);
    if !physical(&d) {
        let cause = match starts_moving(exps) {
            Some((log, fraction)) => UnphysicalCause::StartsMoving { log, fraction },
            None => unphysical_cause(&balance, reference),
        };
        let unphysical = CalibrateError::Unphysical {
            jm: d[0],
            density: d[1],
            torque_scale: d[4],
            cause,
        };
        balance = hold_beam(balance).ok_or(unphysical)?;
        d = balance.derived(&balance.coef, reference);
    }
    // What the free fit gave, when the beam had to be held: said with the result.
    let beam_held = balance.beam_held.then(|| HeldBeam {
        density_kg_m3: balance.params.density_kg_m3,
        free: free.map(|f| (f[0], f[1], f[4])),
        density_given: matches!(reference, Reference::Density(_)),
    });
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
            beam_held,
            rest_offset: None,
            coulomb_asym: None,
        },
    ))
}

/// The first log whose hub already turns at its start (over the first 10 ms, at more
/// than a tenth of its peak rate), and that fraction: a log cut inside a move.
fn starts_moving(exps: &[Experiment]) -> Option<(usize, f64)> {
    exps.iter().enumerate().find_map(|(i, e)| {
        let hub = HubMotion::of(&e.log, 0.01);
        let dt = e.log.t[1] - e.log.t[0];
        let k = ((0.01 / dt).round() as usize).min(hub.omega.len() - 1);
        let peak = hub.omega.iter().fold(0.0f64, |m, w| m.max(w.abs()));
        let fraction = hub.omega[k].abs() / peak;
        (peak > 0.0 && fraction > 0.1).then_some((i, fraction))
    })
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
    match fit_balance_as(&balance.rows, true, balance.beam_held)
        .map(|c| balance.derived(&c, reference))
    {
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
    let coef = fit_balance_as(&balance.rows, true, balance.beam_held).ok()?;
    let resid: Vec<f64> = balance
        .rows
        .iter()
        .map(|r| r.y - r.x.iter().zip(&coef).map(|(x, c)| x * c).sum::<f64>())
        .collect();
    let rms_with = (resid.iter().map(|r| r * r).sum::<f64>() / resid.len().max(1) as f64).sqrt();
    let dt0 = exps[0].log.t[1] - exps[0].log.t[0];
    let block_s = (2.0 * decorrelation_lag(&resid) as f64 * dt0).max(MIN_BLOCK_S);
    let boot: Vec<f64> = bootstrap(&balance.rows, exps, true, balance.beam_held, block_s)
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

/// Coulomb friction that differs by direction, found by the balance with the torque's zero
/// read at rest.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct DirectionalFriction {
    /// Half the difference, N m (positive: more friction turning positive).
    pub asym_nm: f64,
    /// Its one-sigma error (block bootstrap), N m.
    pub std_err_nm: f64,
    /// The balance's residual RMS with the friction the same both ways, N m.
    pub rms_err_without_nm: f64,
    /// With it differing.
    pub rms_err_with_nm: f64,
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
            beam_held: false,
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
