//! System identification from a logged slew (docs/design.md, section 5): the model's parameters are
//! fitted so that the plant, driven open loop by the logged torque, reproduces the logged hub
//! angle (and, last, the root strain).
//!
//! The paper's four steps, on windows found in the log ([`find_windows`]; the paper's are
//! 0..0.35 s and 0.35..0.6 s): (1) mass and stiffness (Jm, density, EI) up to the end of the
//! move on the hub angle alone; (2) friction (viscous b, Coulomb) while the hub settles;
//! (3) all five together over both, each held within +-20 % of steps 1-2; (4) the strain side (root gauge position)
//! and beam coefficients (EI, density) within +-20 %, with the strain term weighted in. Errors
//! are normalised by the sensors' resolution (one encoder count, one microstrain), so the
//! weights W1 and W2 compare like with like. Each step samples its bounds on a Latin hypercube
//! (in parallel), then runs COBYLA from the best sample: with only the hub angle, Jm and the
//! beam's inertia trade against each other and a purely local search stalls.

use crate::fit::minimise;
use crate::fit::Param;
pub use beam_log::{
    lagged, read_log, read_log_with, BeamSensor, Columns, Log, LogError, LogProblem,
};
use beam_sim::plant::{Plant, State};
use model_core::{Beam, BeamParams, EncoderSpec, ModalModel};

/// Scale of the hub-angle error: one encoder count, rad.
fn count_rad() -> f64 {
    EncoderSpec::DEFAULT.rad_per_count()
}

/// Scale of the strain error: one microstrain.
const STRAIN_SCALE: f64 = 1e-6;

/// COBYLA evaluations per local search: the Jm/density valley is long and narrow, and a few
/// hundred evaluations stop well short of its floor (measured: Jm 12 % off at 300, 0.2 % at 3000).
pub const DEFAULT_EVALS: usize = 2000;

fn start_of(p: &BeamParams, which: &[Fitted]) -> Vec<f64> {
    which
        .iter()
        .map(|f| f.range.unit_of(f.quantity.get(p)))
        .collect()
}

/// Why calibration could not run.
#[derive(Debug, thiserror::Error)]
pub enum CalibrateError {
    /// The starting guess is not a valid beam.
    #[error("the starting parameters")]
    Guess(#[from] model_core::ParamError),
    /// No log was given.
    #[error("no log to calibrate on")]
    NoLogs,
    /// The logs measure the beam with different sensors (one a strain gauge, another a tip
    /// sensor): one fit pools their errors, which must share a unit.
    #[error("the logs measure the beam with different sensors ({0} and {1}): calibrate each rig's logs apart")]
    MixedSensors(&'static str, &'static str),
    /// The method needs what this sensor cannot give.
    #[error("{0}")]
    SensorUnsupported(&'static str),
    /// The model left its range during a step.
    #[error("step `{step}`: the model broke down on this log")]
    Breakdown {
        /// The step.
        step: &'static str,
    },
    /// A known density that is not a density.
    #[error("the known density {0} kg/m^3 must be finite and > 0")]
    Reference(f64),
    /// The tip masses are to fix the level, but every log has the same.
    #[error(
        "the tip masses fix the level only from logs recorded with two different masses (the \
         same move with and without a weighed mass added): one mass hardly moves the strain"
    )]
    OneTipMass,
    /// The hub hardly moves in the windows: no torque balance to fit.
    #[error("the hub moves in only {0} samples of the windows; the torque balance needs 20")]
    TooLittleMotion(usize),
    /// A torque offset was asked for, but the logs move one way.
    #[error(
        "a torque offset needs moves both ways (each at least a fifth of the time moving): \
         moving one way it is Coulomb friction"
    )]
    OneWay,
    /// The torque balance came out unphysical: the logs do not determine the rigid body.
    #[error(
        "the torque balance gives Jm {jm:.3e} kg m^2, density {density:.4e} kg/m^3 and torque \
         scale {torque_scale:.3} (each must be > 0, and the density within a factor of 3 of \
         the starting one): {cause}"
    )]
    Unphysical {
        /// The hub's inertia found.
        jm: f64,
        /// The density found.
        density: f64,
        /// The torque scale found.
        torque_scale: f64,
        /// What the balance saw that most likely caused it.
        cause: UnphysicalCause,
    },
}

/// The likely cause of an unphysical torque balance, from what the balance saw.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum UnphysicalCause {
    /// Nothing the balance can test: the general advice.
    Unknown,
    /// A log starts inside a move: the balance's rigid body has no start from rest.
    StartsMoving {
        /// The log's place among the logs, from 0.
        log: usize,
        /// The hub's rate at its start, as a fraction of its peak.
        fraction: f64,
    },
    /// The logs move both ways, and the same balance given a torque offset is physical.
    Offset {
        /// The offset it then finds, N m.
        offset_nm: f64,
        /// Jm it then finds, kg m^2.
        jm: f64,
    },
}

impl std::fmt::Display for UnphysicalCause {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            UnphysicalCause::Unknown => write!(
                f,
                "the logs do not determine the rigid body, or the starting parameters (tip \
                 mass, gauge) do not describe the rig"
            ),
            UnphysicalCause::StartsMoving { log, fraction } => write!(
                f,
                "log {} starts inside a move (its hub already turns at {:.0} % of its peak rate \
                 at the first samples) and the split takes the beam as at rest there: cut it \
                 from before the move (--from), or log the rest before it",
                log + 1,
                100.0 * fraction
            ),
            UnphysicalCause::Offset { offset_nm, jm } => write!(
                f,
                "given a torque offset the same balance is physical ({offset_nm:.3e} N m, Jm \
                 {jm:.3e} kg m^2): the torque's zero is off, or Coulomb friction differs \
                 between the two directions (by twice that); calibrate with --torque-offset"
            ),
        }
    }
}

/// Rest the calibration wants before each move, s: the split's start-up treatment takes the
/// beam as at rest before the hub moves, and a log cut a few milliseconds before the move
/// kicks the model beam (on the other rig's steps: -4.1 / +2.6 % in the first mode as cut,
/// within 0.7 % with 0.1 s of rest).
pub const REST_BEFORE_S: f64 = 0.1;

pub use super::cut::{split_moves, MOVE_GAP_S};

/// Where the steps look, s from the log's first sample: the move (`start_s..end_s`) and the
/// settling after it (`end_s..settle_end_s`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Windows {
    /// The hub starts to move (or the torque rises).
    pub start_s: f64,
    /// The hub has arrived: from here on it stays within 2 % of the move of its final angle.
    pub end_s: f64,
    /// The end of the settling window.
    pub settle_end_s: f64,
}

impl Windows {
    /// The paper's: the 0.35 s slew and 0.25 s after it.
    pub const PAPER: Windows = Windows {
        start_s: 0.0,
        end_s: 0.35,
        settle_end_s: 0.6,
    };

    /// `start,end,settle_end` given by hand, checked against `log`.
    pub fn given(
        start_s: f64,
        end_s: f64,
        settle_end_s: f64,
        log: &Log,
    ) -> Result<Self, LogProblem> {
        let length = log.t[log.t.len() - 1] - log.t[0];
        let ok = start_s.is_finite()
            && end_s.is_finite()
            && settle_end_s.is_finite()
            && 0.0 <= start_s
            && start_s < end_s
            && end_s < settle_end_s
            && settle_end_s <= length + 1e-9;
        if ok {
            Ok(Windows {
                start_s,
                end_s,
                settle_end_s,
            })
        } else {
            Err(LogProblem::BadWindows(length))
        }
    }
}

/// The windows of the move in `log`, found from the logged angle and torque, wherever it
/// starts and whatever its amplitude: the move starts where the hub has left its first angle
/// by 2 % of the move or the torque has left its level at rest before the move (the median
/// over the rest, where there is [`REST_BEFORE_S`] of it; else zero) by 5 % of its largest
/// departure, whichever comes first; it
/// ends where the hub is within 2 % of the move of its final angle (the mean of the last
/// 5 % of the log) for good; the settling window runs on for the longer of 0.25 s and 70 %
/// of the move (the paper's proportions), or to the end of the log.
pub fn find_windows(log: &Log) -> Result<Windows, LogProblem> {
    let n = log.t.len();
    let t = |k: usize| log.t[k] - log.t[0];
    let first = log.theta[0];
    let tail = (n / 20).max(1);
    let last = log.theta[n - tail..].iter().sum::<f64>() / tail as f64;
    let travel = last - first;
    // Ten encoder counts: below that there is no move to speak of.
    if travel.abs() < 10.0 * count_rad() {
        return Err(LogProblem::NoMove(travel.abs()));
    }
    let band = 0.02 * travel.abs();
    // The torque from its level at rest before the move, where the log has at least
    // REST_BEFORE_S of it (the median over the rest, the hub not yet off its first angle):
    // a torque read with an offset (one derived from a motor's voltage) is not a move. A
    // log that starts moving at once has no level to take: zero.
    let still = (0..n)
        .find(|&k| (log.theta[k] - first).abs() > band)
        .unwrap_or(n);
    let level = if t(still.min(n - 1)) >= REST_BEFORE_S {
        let mut rest: Vec<f64> = log.torque[..still].to_vec();
        rest.sort_by(f64::total_cmp);
        rest[rest.len() / 2]
    } else {
        0.0
    };
    let peak_torque = log
        .torque
        .iter()
        .fold(0.0f64, |m, &u| m.max((u - level).abs()));
    let start = (0..n)
        .find(|&k| {
            (log.theta[k] - first).abs() > band
                || (log.torque[k] - level).abs() > 0.05 * peak_torque
        })
        .unwrap_or(0);
    let end = (0..n)
        .rev()
        .find(|&k| (log.theta[k] - last).abs() > band)
        .map_or(start + 1, |k| (k + 1).min(n - 1));
    let (start_s, end_s) = (t(start), t(end.max(start + 1).min(n - 1)));
    let settle_end_s = (end_s + (0.25f64).max(0.7 * (end_s - start_s))).min(t(n - 1));
    if settle_end_s - end_s < 0.05 {
        return Err(LogProblem::EndsEarly(settle_end_s - end_s));
    }
    Ok(Windows {
        start_s,
        end_s,
        settle_end_s,
    })
}

/// A parameter the steps fit.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Quantity {
    Jm,
    Density,
    Ei,
    Viscous,
    Coulomb,
    RootGauge,
}

impl Quantity {
    /// The five of steps 1-3, in order.
    const RIGID_AND_FRICTION: [Quantity; 5] = [
        Quantity::Jm,
        Quantity::Density,
        Quantity::Ei,
        Quantity::Viscous,
        Quantity::Coulomb,
    ];

    /// Its `BeamParams` field.
    fn name(self) -> &'static str {
        match self {
            Quantity::Jm => "jm_kgm2",
            Quantity::Density => "density_kg_m3",
            Quantity::Ei => "ei_nm2",
            Quantity::Viscous => "viscous_nms",
            Quantity::Coulomb => "coulomb_nm",
            Quantity::RootGauge => "root_gauge_m",
        }
    }

    fn field(self, p: &mut BeamParams) -> &mut f64 {
        match self {
            Quantity::Jm => &mut p.jm_kgm2,
            Quantity::Density => &mut p.density_kg_m3,
            Quantity::Ei => &mut p.ei_nm2,
            Quantity::Viscous => &mut p.viscous_nms,
            Quantity::Coulomb => &mut p.coulomb_nm,
            Quantity::RootGauge => &mut p.root_gauge_m,
        }
    }

    fn get(self, p: &BeamParams) -> f64 {
        *self.field(&mut p.clone())
    }

    fn set(self, p: &mut BeamParams, v: f64) {
        *self.field(p) = v;
    }
}

/// One parameter of a step: what, and the range searched (the optimiser's [`Param`]).
#[derive(Clone, Copy, Debug)]
struct Fitted {
    quantity: Quantity,
    range: Param,
}

impl Fitted {
    fn new(quantity: Quantity, lo: f64, hi: f64, log: bool) -> Self {
        Fitted {
            quantity,
            range: Param {
                name: quantity.name(),
                lo,
                hi,
                log,
            },
        }
    }
}

/// Replays the log's torque through the plant with `params`: the simulated hub angle and
/// beam signal (the log's [`BeamSensor`]) at each sample up to `t_end`, with RK4 at a step inside its stability region. `None` if the parameters are invalid or the model
/// breaks down.
pub fn replay<const N: usize>(
    params: &BeamParams,
    log: &Log,
    t_end: f64,
) -> Option<(Vec<f64>, Vec<f64>)> {
    let model = ModalModel::<N>::try_build(&Beam::try_build(*params).ok()?).ok()?;
    let plant = Plant::new(model);
    let dt = log.t[1] - log.t[0];
    // At least four RK4 steps a sample, and as many more as keep each step inside the
    // method's stability region: near rest the smoothed Coulomb term is stiff, and a fixed
    // quarter sample (0.5 ms at 500 Hz) is not (Plant::stable_step_s).
    let steps = ((dt / plant.stable_step_s()).ceil() as usize).clamp(4, 10_000);
    let h = dt / steps as f64;
    let mut x = State::<N>::at_rest(log.theta[0]);
    let row = log.sensor.coef(&plant.model);
    let (mut th, mut eps) = (Vec::new(), Vec::new());
    for k in 0..log.t.len() {
        th.push(x.theta);
        eps.push(model_core::linalg::dot(&row, &x.q));
        if log.t[k] - log.t[0] >= t_end - 1e-9 {
            break;
        }
        let tau = plant.saturate(log.torque[k]);
        for _ in 0..steps {
            x = plant.rk4_step(&x, tau, h);
        }
        plant.check_validity(&x).ok()?;
    }
    Some((th, eps))
}

/// Which part of each log a step fits.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Part {
    /// From the log's start to the end of the move.
    Move,
    /// The settling after the move.
    Settle,
    /// Both.
    All,
}

impl Part {
    fn window(self, w: &Windows) -> (f64, f64) {
        match self {
            Part::Move => (0.0, w.end_s),
            Part::Settle => (w.end_s, w.settle_end_s),
            Part::All => (0.0, w.settle_end_s),
        }
    }
}

/// Weights and part of one step's fit error.
#[derive(Clone, Copy, Debug)]
struct Fit {
    part: Part,
    w1: f64,
    w2: f64,
}

/// A log and its windows: one experiment to calibrate on.
#[derive(Clone, Debug, PartialEq)]
pub struct Experiment {
    /// The log.
    pub log: Log,
    /// Its windows.
    pub windows: Windows,
    /// The tip mass it was logged with, kg, when not the parameters' (a weighed mass added
    /// for this log: see [`crate::identify::split::Reference::TipMass`]).
    pub tip_mass_kg: Option<f64>,
    /// Whether the rest before the move is where the log begins, the hub not yet moved in
    /// it (its first move; a later move of a log cut into several rests where the last one
    /// stopped, held there by friction with a torque that need not be the torque's zero).
    pub rest_is_start: bool,
}

impl Experiment {
    /// A log and its windows, logged with the parameters' tip mass, its move the log's
    /// first.
    pub fn new(log: Log, windows: Windows) -> Self {
        Self {
            log,
            windows,
            tip_mass_kg: None,
            rest_is_start: true,
        }
    }

    /// `p` as this log was recorded: with its tip mass.
    pub fn params(&self, p: &BeamParams) -> BeamParams {
        BeamParams {
            tip_mass_kg: self.tip_mass_kg.unwrap_or(p.tip_mass_kg),
            ..*p
        }
    }
}

/// Sums of squared hub-angle error (rad^2) and beam-signal error (ue^2 of root strain, or
/// mm^2 of tip deflection: [`BeamSensor::unit`]) over the step's part of one log, and the
/// number of samples.
fn squared_errors<const N: usize>(
    params: &BeamParams,
    e: &Experiment,
    part: Part,
) -> Option<(f64, f64, usize)> {
    let (a, b) = part.window(&e.windows);
    let log = &e.log;
    let (th, eps) = replay::<N>(&e.params(params), log, b)?;
    let t0 = log.t[0];
    let (mut se, mut ss, mut n) = (0.0, 0.0, 0usize);
    for k in 0..th.len() {
        let t = log.t[k] - t0;
        if t >= a - 1e-9 && t <= b + 1e-9 {
            se += (th[k] - log.theta[k]).powi(2);
            ss += ((eps[k] - log.beam_signal[k]) * log.sensor.display_scale()).powi(2);
            n += 1;
        }
    }
    Some((se, ss, n))
}

/// RMS hub-angle error (rad) and RMS root-strain error (microstrain) pooled over the
/// experiments' parts, and the weighted cost W1 mean((e_theta/count)^2) +
/// W2 mean((e_strain/1e-6)^2).
fn fit_error<const N: usize>(
    params: &BeamParams,
    exps: &[Experiment],
    fit: Fit,
) -> Option<(f64, f64, f64)> {
    let (mut se, mut ss, mut n) = (0.0, 0.0, 0usize);
    for e in exps {
        let (a, b, m) = squared_errors::<N>(params, e, fit.part)?;
        se += a;
        ss += b;
        n += m;
    }
    let n = n.max(1) as f64;
    let c = count_rad();
    Some((
        (se / n).sqrt(),
        (ss / n).sqrt(),
        fit.w1 * se / n / (c * c) + fit.w2 * ss / n * (1e-6 / STRAIN_SCALE).powi(2),
    ))
}

/// How well `p` fits each log over its move and settling; `None` if the model breaks down.
pub fn log_fits<const N: usize>(p: &BeamParams, exps: &[Experiment]) -> Option<Vec<LogFit>> {
    exps.iter()
        .map(|e| {
            let (se, ss, n) = squared_errors::<N>(p, e, Part::All)?;
            let n = n.max(1) as f64;
            Some(LogFit {
                rms_theta_err_rad: (se / n).sqrt(),
                rms_beam_err: (ss / n).sqrt(),
            })
        })
        .collect()
}

/// How well the identified model fits one log (over its move and settling).
#[derive(Clone, Debug, PartialEq)]
pub struct LogFit {
    /// RMS hub-angle error, rad.
    pub rms_theta_err_rad: f64,
    /// RMS error of the beam's signal, in its display unit ([`BeamSensor::unit`]: ue of
    /// root strain, mm of tip deflection).
    pub rms_beam_err: f64,
}

/// One step's outcome.
#[derive(Clone, Debug, PartialEq)]
pub struct StepReport {
    /// What the step fits.
    pub name: &'static str,
    /// The window, s, in the first log.
    pub window: (f64, f64),
    /// The parameters fitted in the step and their values after it.
    pub fitted: Vec<(&'static str, f64)>,
    /// RMS hub-angle error over the window (of every log) after the step, rad.
    pub rms_theta_err_rad: f64,
    /// RMS root-strain error over the window (of every log) after the step, microstrain.
    pub rms_strain_err_ue: f64,
    /// The step's parameters that ended on a bound of its search.
    pub at_bound: Vec<AtBound>,
}

/// A fitted parameter that ended on (or beyond) a bound of its search: the logs push it
/// further than the search lets it go, so its value is the bound's, not the logs'.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct AtBound {
    /// The parameter.
    pub name: &'static str,
    /// Its value.
    pub value: f64,
    /// The bound it sits on.
    pub bound: f64,
    /// `lower` or `upper`.
    pub side: &'static str,
}

/// A result within this fraction of its search's range (in the search's own coordinate,
/// logarithmic where the search is) of a bound is said to be on it.
pub const BOUND_TOLERANCE: f64 = 1e-3;

impl AtBound {
    /// `Some` when `value` is on a bound of `range` (see [`BOUND_TOLERANCE`]).
    pub fn check(range: &Param, value: f64) -> Option<Self> {
        let u = if range.log {
            (value.max(f64::MIN_POSITIVE).ln() - range.lo.ln()) / (range.hi.ln() - range.lo.ln())
        } else {
            (value - range.lo) / (range.hi - range.lo)
        };
        let (bound, side) = if u.is_nan() || range.hi <= range.lo {
            return None;
        } else if u <= BOUND_TOLERANCE {
            (range.lo, "lower")
        } else if u >= 1.0 - BOUND_TOLERANCE {
            (range.hi, "upper")
        } else {
            return None;
        };
        Some(AtBound {
            name: range.name,
            value,
            bound,
            side,
        })
    }
}

/// The local searches' tolerance on the point (relative) where nothing polishes their result.
pub(crate) const SEARCH_XTOL: f64 = 1e-6;

/// Fits the `which` parameters of `p`, within their ranges, to minimise the step's error.
fn fit_step<const N: usize>(
    p: &mut BeamParams,
    log: &[Experiment],
    which: &[Fitted],
    fit: Fit,
    evals: usize,
) {
    let start = start_of(p, which);
    let base = *p;
    let at = |u: &[f64]| {
        let mut q = base;
        for (f, &u) in which.iter().zip(u) {
            f.quantity.set(&mut q, f.range.gain_at(u));
        }
        q
    };
    // ln of the error: it spans decades between a good and a poor fit.
    let objective =
        |u: &[f64]| fit_error::<N>(&at(u), log, fit).map_or(1e3, |e| e.2.max(1e-300).ln());
    let best = minimise(
        which.len(),
        start,
        evals,
        0x5EED ^ which.len() as u64,
        SEARCH_XTOL,
        &objective,
    );
    // Keep the start if the search made things worse (it reports its last point on failure).
    let before = fit_error::<N>(p, log, fit).map_or(f64::INFINITY, |e| e.2);
    let after = fit_error::<N>(&at(&best), log, fit).map_or(f64::INFINITY, |e| e.2);
    if after < before {
        *p = at(&best);
    }
}

/// How well one identified parameter is determined.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Uncertainty {
    /// The parameter.
    pub name: &'static str,
    /// Its value.
    pub value: f64,
    /// Its standard error (one sigma), from the fit's Jacobian.
    pub std_err: f64,
}

/// Two parameters the logs cannot tell apart well.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Tradeoff {
    /// One parameter.
    pub a: &'static str,
    /// The other.
    pub b: &'static str,
    /// Their estimated correlation.
    pub correlation: f64,
}

/// Correlation above which two parameters are reported as trading against each other.
pub const TRADEOFF_CORRELATION: f64 = 0.9;

/// Standard errors and trade-offs of Jm, density, EI, viscous and Coulomb friction and the
/// gauge position at `p`, from the Gauss-Newton approximation `cov = s^2 (J'J)^-1` of the
/// residuals (hub angle in encoder counts, root strain in microstrain, over every log's move
/// and settling), with `s^2` the residual variance and the Jacobian by central differences.
/// They describe how the logs constrain the parameters near `p` (noise and quantisation),
/// not how far the search stopped from the best fit. `None` if a parameter has no effect on
/// the residuals (J'J singular) or the model breaks down.
pub fn uncertainty<const N: usize>(
    p: &BeamParams,
    exps: &[Experiment],
) -> Option<(Vec<Uncertainty>, Vec<Tradeoff>)> {
    let which = [
        Quantity::Jm,
        Quantity::Density,
        Quantity::Ei,
        Quantity::Viscous,
        Quantity::Coulomb,
        Quantity::RootGauge,
    ];
    let residuals = |q: &BeamParams| -> Option<Vec<f64>> {
        let mut r = vec![];
        for e in exps {
            let (a, b) = Part::All.window(&e.windows);
            let (th, eps) = replay::<N>(&e.params(q), &e.log, b)?;
            let t0 = e.log.t[0];
            for k in 0..th.len() {
                let t = e.log.t[k] - t0;
                if t >= a - 1e-9 && t <= b + 1e-9 {
                    r.push((th[k] - e.log.theta[k]) / count_rad());
                    r.push((eps[k] - e.log.beam_signal[k]) / STRAIN_SCALE);
                }
            }
        }
        Some(r)
    };
    let r0 = residuals(p)?;
    let m = r0.len();
    let n = which.len();
    if m <= n {
        return None;
    }
    // Columns of J by central differences, with steps of 0.1 % of each value, but no
    // smaller than a floor for the parameters that may sit at zero (friction, the gauge's
    // position), where a relative step would vanish.
    let mut jac = vec![vec![0.0; n]; m];
    for (j, q) in which.iter().enumerate() {
        let v = q.get(p);
        let floor = match q {
            Quantity::Coulomb => 1e-4,
            Quantity::Viscous => 1e-6,
            Quantity::RootGauge => 1e-4,
            Quantity::Jm | Quantity::Density | Quantity::Ei => 0.0,
        };
        let h = (1e-3 * v.abs()).max(floor);
        if h <= 0.0 {
            return None;
        }
        let (mut up, mut down) = (*p, *p);
        q.set(&mut up, v + h);
        q.set(&mut down, (v - h).max(0.0));
        let dh = q.get(&up) - q.get(&down);
        let (ru, rd) = (residuals(&up)?, residuals(&down)?);
        if ru.len() != m || rd.len() != m {
            return None;
        }
        for i in 0..m {
            jac[i][j] = (ru[i] - rd[i]) / dh;
        }
    }
    let mut jtj = vec![vec![0.0; n]; n];
    for row in &jac {
        for a in 0..n {
            for b in 0..n {
                jtj[a][b] += row[a] * row[b];
            }
        }
    }
    let inv = crate::identify::lsq::invert(jtj)?;
    let s2 = r0.iter().map(|x| x * x).sum::<f64>() / (m - n) as f64;
    let se: Vec<f64> = (0..n).map(|i| (s2 * inv[i][i]).max(0.0).sqrt()).collect();
    let out = which
        .iter()
        .zip(&se)
        .map(|(q, &e)| Uncertainty {
            name: q.name(),
            value: q.get(p),
            std_err: e,
        })
        .collect();
    let mut trades = vec![];
    for a in 0..n {
        for b in a + 1..n {
            let c = inv[a][b] / (inv[a][a] * inv[b][b]).sqrt();
            if c.abs() > TRADEOFF_CORRELATION {
                trades.push(Tradeoff {
                    a: which[a].name(),
                    b: which[b].name(),
                    correlation: c,
                });
            }
        }
    }
    Some((out, trades))
}

/// Runs the four steps from `guess` on `log` with an `N`-mode model.
pub fn calibrate<const N: usize>(
    log: &Log,
    guess: &BeamParams,
    evals: usize,
    windows: &Windows,
) -> Result<(BeamParams, Vec<StepReport>), CalibrateError> {
    let exps = [Experiment::new(log.clone(), *windows)];
    calibrate_many::<N>(&exps, guess, evals).map(|(p, steps, _)| (p, steps))
}

/// Runs the four steps from `guess` on all the experiments at once (one parameter set for
/// every log: each step's error pools its part of every log), with an `N`-mode model; and
/// how well the result fits each log.
pub fn calibrate_many<const N: usize>(
    exps: &[Experiment],
    guess: &BeamParams,
    evals: usize,
) -> Result<(BeamParams, Vec<StepReport>, Vec<LogFit>), CalibrateError> {
    let log = exps;
    let first = exps.first().ok_or(CalibrateError::NoLogs)?.windows;
    if exps.iter().any(|e| e.log.sensor != BeamSensor::RootStrain) {
        return Err(CalibrateError::SensorUnsupported(
            "the paper's method fits the root gauge's position on the root strain: a log of \
             the tip's deflection calibrates with --method split",
        ));
    }
    Beam::try_build(*guess)?;
    let mut p = *guess;
    let mut reports = Vec::new();
    let wide = |q: Quantity, p: &BeamParams| {
        let v = q.get(p);
        Fitted::new(q, v / 2.0, v * 2.0, true)
    };
    let friction = |q: Quantity, p: &BeamParams, floor: f64| {
        Fitted::new(q, 0.0, (4.0 * q.get(p)).max(floor), false)
    };
    let mut report = |step, fit: Fit, which: &[Fitted], p: &BeamParams| {
        let (et, es, _) = fit_error::<N>(p, log, fit).ok_or(CalibrateError::Breakdown { step })?;
        reports.push(StepReport {
            name: step,
            window: fit.part.window(&first),
            fitted: which
                .iter()
                .map(|f| (f.quantity.name(), f.quantity.get(p)))
                .collect(),
            rms_theta_err_rad: et,
            rms_strain_err_ue: es,
            at_bound: which
                .iter()
                .filter_map(|f| AtBound::check(&f.range, f.quantity.get(p)))
                .collect(),
        });
        Ok::<(), CalibrateError>(())
    };
    // 1. Mass and stiffness, on the hub angle during the move.
    let fit1 = Fit {
        part: Part::Move,
        w1: 1.0,
        w2: 0.0,
    };
    let s1 = [Quantity::Jm, Quantity::Density, Quantity::Ei].map(|q| wide(q, &p));
    fit_step::<N>(&mut p, log, &s1, fit1, evals);
    report("mass and stiffness", fit1, &s1, &p)?;
    // 2. Friction, after the move.
    let fit2 = Fit {
        part: Part::Settle,
        w1: 1.0,
        w2: 0.0,
    };
    let s2 = [
        friction(Quantity::Viscous, &p, 1e-3),
        friction(Quantity::Coulomb, &p, 0.05),
    ];
    fit_step::<N>(&mut p, log, &s2, fit2, evals);
    report("friction", fit2, &s2, &p)?;
    // 3. All of them, within +-20 % of steps 1-2.
    let fit3 = Fit {
        part: Part::All,
        w1: 1.0,
        w2: 0.0,
    };
    let s3 = Quantity::RIGID_AND_FRICTION.map(|q| {
        let v = q.get(&p);
        match q {
            Quantity::Viscous | Quantity::Coulomb => {
                Fitted::new(q, 0.8 * v, (1.2 * v).max(1e-6), false)
            }
            _ => Fitted::new(q, 0.8 * v, 1.2 * v, true),
        }
    });
    fit_step::<N>(&mut p, log, &s3, fit3, evals);
    report("all, within 20 %", fit3, &s3, &p)?;
    // 4. The strain side: where the root gauge sits and the beam coefficients (EI and
    // density, within 20 % of step 3), with the strain term weighted in.
    let fit4 = Fit {
        part: Part::All,
        w1: 1.0,
        w2: 1.0,
    };
    let s4 = [
        Fitted::new(Quantity::RootGauge, 0.0, 0.2 * p.length_m, false),
        Fitted::new(
            Quantity::Density,
            0.8 * p.density_kg_m3,
            1.2 * p.density_kg_m3,
            true,
        ),
        Fitted::new(Quantity::Ei, 0.8 * p.ei_nm2, 1.2 * p.ei_nm2, true),
    ];
    fit_step::<N>(&mut p, log, &s4, fit4, evals);
    report("strain side", fit4, &s4, &p)?;
    let per_log = exps
        .iter()
        .map(|e| {
            let (se, ss, n) =
                squared_errors::<N>(&p, e, Part::All).ok_or(CalibrateError::Breakdown {
                    step: "per-log fit",
                })?;
            let n = n.max(1) as f64;
            Ok(LogFit {
                rms_theta_err_rad: (se / n).sqrt(),
                rms_beam_err: (ss / n).sqrt(),
            })
        })
        .collect::<Result<Vec<_>, CalibrateError>>()?;
    Ok((p, reports, per_log))
}
