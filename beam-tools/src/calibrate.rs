//! System identification from a logged slew (docs/design.md, section 5): the model's parameters are
//! fitted so that the plant, driven open loop by the logged torque, reproduces the logged hub
//! angle (and, last, the root strain).
//!
//! The paper's four steps: (1) mass and stiffness (Jm, density, EI) over 0..0.35 s on the hub
//! angle alone; (2) friction (viscous b, Coulomb) over 0.35..0.6 s; (3) all five together over
//! 0..0.6 s, each held within +-20 % of steps 1-2; (4) the strain side (root gauge position)
//! and beam coefficients (EI, density) within +-20 %, with the strain term weighted in. Errors
//! are normalised by the sensors' resolution (one encoder count, one microstrain), so the
//! weights W1 and W2 compare like with like. Each step samples its bounds on a Latin hypercube
//! (in parallel), then runs COBYLA from the best sample: with only the hub angle, Jm and the
//! beam's inertia trade against each other and a purely local search stalls.

use crate::optimize::{latin_hypercube, Param};
use host_tests::plant::{Plant, State};
use model_core::{Beam, BeamParams, EncoderSpec, ModalModel};
use rayon::prelude::*;

/// Scale of the hub-angle error: one encoder count, rad.
fn count_rad() -> f64 {
    EncoderSpec::DEFAULT.rad_per_count()
}

/// Scale of the strain error: one microstrain.
const STRAIN_SCALE: f64 = 1e-6;

/// Latin-hypercube samples per step before the local search.
const SAMPLES: usize = 96;

/// COBYLA evaluations per local search: the Jm/density valley is long and narrow, and a few
/// hundred evaluations stop well short of its floor (measured: Jm 12 % off at 300, 0.2 % at 3000).
pub const DEFAULT_EVALS: usize = 2000;

/// Local searches per step (besides the one from the current values).
const LOCAL_STARTS: usize = 5;

fn start_of(p: &BeamParams, which: &[Fitted]) -> Vec<f64> {
    which
        .iter()
        .map(|f| f.range.unit_of(f.quantity.get(p)))
        .collect()
}

/// A log that cannot be calibrated on: the file, the line (1-based) where there is one, and
/// the problem.
#[derive(Debug, thiserror::Error)]
#[error("{file}{}: {problem}", line.map(|l| format!(": line {l}")).unwrap_or_default())]
pub struct LogError {
    /// The file, as given.
    pub file: String,
    /// The line, if the problem is on one.
    pub line: Option<usize>,
    /// What is wrong.
    pub problem: LogProblem,
}

/// What is wrong with a log.
#[derive(Debug, thiserror::Error)]
pub enum LogProblem {
    /// No header.
    #[error("empty file")]
    Empty,
    /// A required column is missing.
    #[error("no `{column}` column (header: {header})")]
    MissingColumn {
        /// The column.
        column: &'static str,
        /// The header line.
        header: String,
    },
    /// A row with the wrong number of fields.
    #[error("{got} fields, the header has {header}")]
    FieldCount {
        /// Fields in the row.
        got: usize,
        /// Fields in the header.
        header: usize,
    },
    /// A field that is not a number.
    #[error("column `{column}`: `{text}` is not a number")]
    NotANumber {
        /// The column.
        column: String,
        /// What was there.
        text: String,
    },
    /// A NaN or infinite value.
    #[error("column `{column}`: {value} is not finite")]
    NonFinite {
        /// The column.
        column: String,
        /// The value.
        value: f64,
    },
    /// Time that stands still or goes back.
    #[error("column `t_s`: time {0} does not increase")]
    TimeNotIncreasing(f64),
    /// A change of sample period.
    #[error("column `t_s`: the sample period changes (uniform sampling needed)")]
    NonUniform,
    /// Too few samples.
    #[error("{0} samples: at least 100 (0.1 s at 1 kHz) are needed")]
    TooShort(usize),
    /// The log stops before the steps' windows end.
    #[error("the log ends before 0.6 s: the four steps need 0..0.6 s")]
    EndsEarly,
}

/// Why calibration could not run.
#[derive(Debug, thiserror::Error)]
pub enum CalibrateError {
    /// The starting guess is not a valid beam.
    #[error("the starting parameters")]
    Guess(#[from] model_core::ParamError),
    /// The model left its range during a step.
    #[error("step `{step}`: the model broke down on this log")]
    Breakdown {
        /// The step.
        step: &'static str,
    },
}

/// A logged run: uniformly sampled time, applied torque, measured hub angle and root strain.
#[derive(Clone, Debug, PartialEq)]
pub struct Log {
    /// Sample times, s (uniform).
    pub t: Vec<f64>,
    /// Torque applied over the following sample, N m.
    pub torque: Vec<f64>,
    /// Measured hub angle, rad.
    pub theta: Vec<f64>,
    /// Measured root strain.
    pub root_strain: Vec<f64>,
    /// Mid-span strain, if logged.
    pub mid_strain: Option<Vec<f64>>,
}

/// Reads a log CSV: a header naming at least `t_s,torque_nm,theta_rad,root_strain` (and
/// optionally `mid_strain`; other columns are ignored), then one row per sample. Errors name
/// the file, the line and the column.
pub fn read_log(text: &str, file: &str) -> Result<Log, LogError> {
    let err = |line, problem| LogError {
        file: file.to_string(),
        line,
        problem,
    };
    let mut lines = text
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty());
    let (_, header) = lines.next().ok_or(err(None, LogProblem::Empty))?;
    let names: Vec<&str> = header.split(',').map(str::trim).collect();
    let col = |name: &str| names.iter().position(|n| *n == name);
    let need = |name: &'static str| {
        col(name).ok_or_else(|| {
            err(
                Some(1),
                LogProblem::MissingColumn {
                    column: name,
                    header: header.to_string(),
                },
            )
        })
    };
    let (it, iu, ith, ie) = (
        need("t_s")?,
        need("torque_nm")?,
        need("theta_rad")?,
        need("root_strain")?,
    );
    let im = col("mid_strain");
    let mut log = Log {
        t: vec![],
        torque: vec![],
        theta: vec![],
        root_strain: vec![],
        mid_strain: im.map(|_| vec![]),
    };
    for (n, line) in lines {
        let fields: Vec<&str> = line.split(',').map(str::trim).collect();
        let at = |problem| err(Some(n + 1), problem);
        if fields.len() != names.len() {
            return Err(at(LogProblem::FieldCount {
                got: fields.len(),
                header: names.len(),
            }));
        }
        let num = |i: usize| -> Result<f64, LogError> {
            let v: f64 = fields[i].parse().map_err(|_| {
                at(LogProblem::NotANumber {
                    column: names[i].to_string(),
                    text: fields[i].to_string(),
                })
            })?;
            if v.is_finite() {
                Ok(v)
            } else {
                Err(at(LogProblem::NonFinite {
                    column: names[i].to_string(),
                    value: v,
                }))
            }
        };
        let t = num(it)?;
        if let Some(&prev) = log.t.last() {
            if t <= prev {
                return Err(at(LogProblem::TimeNotIncreasing(t)));
            }
        }
        log.t.push(t);
        log.torque.push(num(iu)?);
        log.theta.push(num(ith)?);
        log.root_strain.push(num(ie)?);
        if let (Some(i), Some(m)) = (im, log.mid_strain.as_mut()) {
            m.push(num(i)?);
        }
    }
    if log.t.len() < 100 {
        return Err(err(None, LogProblem::TooShort(log.t.len())));
    }
    let dt = log.t[1] - log.t[0];
    if let Some(k) = log
        .t
        .windows(2)
        .position(|w| ((w[1] - w[0]) - dt).abs() > 1e-3 * dt)
    {
        return Err(err(Some(k + 3), LogProblem::NonUniform));
    }
    if *log.t.last().unwrap_or(&0.0) < 0.6 - 1e-9 {
        return Err(err(None, LogProblem::EndsEarly));
    }
    Ok(log)
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

/// Replays the log's torque through the plant with `params`: the simulated hub angle and root
/// strain at each sample up to `t_end`. `None` if the parameters are invalid or the model
/// breaks down.
pub fn replay<const N: usize>(
    params: &BeamParams,
    log: &Log,
    t_end: f64,
) -> Option<(Vec<f64>, Vec<f64>)> {
    let model = ModalModel::<N>::try_build(&Beam::try_build(*params).ok()?).ok()?;
    let plant = Plant::new(model);
    let dt = log.t[1] - log.t[0];
    let mut x = State::<N>::at_rest(log.theta[0]);
    let (mut th, mut eps) = (Vec::new(), Vec::new());
    for k in 0..log.t.len() {
        th.push(x.theta);
        eps.push(plant.outputs(&x).root_strain);
        if log.t[k] - log.t[0] >= t_end - 1e-9 {
            break;
        }
        let tau = plant.saturate(log.torque[k]);
        for _ in 0..4 {
            x = plant.rk4_step(&x, tau, dt / 4.0);
        }
        plant.check_validity(&x).ok()?;
    }
    Some((th, eps))
}

/// Weights and window of one step's fit error.
#[derive(Clone, Copy, Debug)]
struct Fit {
    window: (f64, f64),
    w1: f64,
    w2: f64,
}

/// RMS hub-angle error (rad) and RMS root-strain error (microstrain) over the window, and the
/// weighted cost W1 mean((e_theta/count)^2) + W2 mean((e_strain/1e-6)^2).
fn fit_error<const N: usize>(params: &BeamParams, log: &Log, fit: Fit) -> Option<(f64, f64, f64)> {
    let (th, eps) = replay::<N>(params, log, fit.window.1)?;
    let t0 = log.t[0];
    let (mut se, mut ss, mut n) = (0.0, 0.0, 0usize);
    for k in 0..th.len() {
        let t = log.t[k] - t0;
        if t >= fit.window.0 - 1e-9 && t <= fit.window.1 + 1e-9 {
            se += (th[k] - log.theta[k]).powi(2);
            ss += ((eps[k] - log.root_strain[k]) * 1e6).powi(2);
            n += 1;
        }
    }
    let n = n.max(1) as f64;
    let c = count_rad();
    Some((
        (se / n).sqrt(),
        (ss / n).sqrt(),
        fit.w1 * se / n / (c * c) + fit.w2 * ss / n * (1e-6 / STRAIN_SCALE).powi(2),
    ))
}

/// One step's outcome.
#[derive(Clone, Debug, PartialEq)]
pub struct StepReport {
    /// What the step fits.
    pub name: &'static str,
    /// The window, s.
    pub window: (f64, f64),
    /// The parameters fitted in the step and their values after it.
    pub fitted: Vec<(&'static str, f64)>,
    /// RMS hub-angle error over the window after the step, rad.
    pub rms_theta_err_rad: f64,
    /// RMS root-strain error over the window after the step, microstrain.
    pub rms_strain_err_ue: f64,
}

/// Fits the `which` parameters of `p`, within their ranges, to minimise the step's error.
fn fit_step<const N: usize>(
    p: &mut BeamParams,
    log: &Log,
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
    let objective = |u: &[f64], _: &mut ()| {
        fit_error::<N>(&at(u), log, fit).map_or(1e3, |e| e.2.max(1e-300).ln())
    };
    // Global stage: a Latin hypercube over the bounds, best first.
    let candidates = latin_hypercube(SAMPLES, which.len(), 0x5EED ^ which.len() as u64);
    let mut scored: Vec<(f64, Vec<f64>)> = candidates
        .par_iter()
        .map(|u| (objective(u, &mut ()), u.clone()))
        .collect();
    scored.sort_by(|a, b| a.0.total_cmp(&b.0));
    // Local stage from the guess and the best few samples: the cost has several basins.
    let mut starts: Vec<Vec<f64>> = vec![start];
    starts.extend(scored.into_iter().take(LOCAL_STARTS).map(|(_, u)| u));
    let bounds = vec![(0.0, 1.0); which.len()];
    let finals: Vec<(f64, Vec<f64>)> = starts
        .par_iter()
        .map(|u0| {
            let cons: [&dyn cobyla::Func<()>; 0] = [];
            let u = match cobyla::minimize(
                objective,
                u0,
                &bounds,
                &cons,
                (),
                evals,
                cobyla::RhoBeg::All(0.1),
                Some(cobyla::StopTols {
                    xtol_rel: 1e-6,
                    ..Default::default()
                }),
            ) {
                Ok((_, u, _)) | Err((_, u, _)) => u,
            };
            (objective(&u, &mut ()), u)
        })
        .collect();
    let best = finals
        .into_iter()
        .min_by(|a, b| a.0.total_cmp(&b.0))
        .map(|(_, u)| u)
        .unwrap_or_else(|| start_of(p, which));
    // Keep the start if the search made things worse (it reports its last point on failure).
    let before = fit_error::<N>(p, log, fit).map_or(f64::INFINITY, |e| e.2);
    let after = fit_error::<N>(&at(&best), log, fit).map_or(f64::INFINITY, |e| e.2);
    if after < before {
        *p = at(&best);
    }
}

/// Runs the four steps from `guess` on `log` with an `N`-mode model.
pub fn calibrate<const N: usize>(
    log: &Log,
    guess: &BeamParams,
    evals: usize,
) -> Result<(BeamParams, Vec<StepReport>), CalibrateError> {
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
            window: fit.window,
            fitted: which
                .iter()
                .map(|f| (f.quantity.name(), f.quantity.get(p)))
                .collect(),
            rms_theta_err_rad: et,
            rms_strain_err_ue: es,
        });
        Ok::<(), CalibrateError>(())
    };
    let t_end = (log.t[log.t.len() - 1] - log.t[0]).min(0.6);
    // 1. Mass and stiffness, on the hub angle during the move.
    let fit1 = Fit {
        window: (0.0, 0.35),
        w1: 1.0,
        w2: 0.0,
    };
    let s1 = [Quantity::Jm, Quantity::Density, Quantity::Ei].map(|q| wide(q, &p));
    fit_step::<N>(&mut p, log, &s1, fit1, evals);
    report("mass and stiffness", fit1, &s1, &p)?;
    // 2. Friction, after the move.
    let fit2 = Fit {
        window: (0.35, t_end),
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
        window: (0.0, t_end),
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
        window: (0.0, t_end),
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
    Ok((p, reports))
}
