//! System identification from a logged slew (DESIGN section 5): the model's parameters are
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

fn start_of(p: &BeamParams, which: &[(usize, f64, f64, bool)], params: &[Param]) -> Vec<f64> {
    which
        .iter()
        .zip(params)
        .map(|(&(i, ..), q)| q.unit_of(get(p, i)))
        .collect()
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
pub fn read_log(text: &str, file: &str) -> Result<Log, String> {
    let mut lines = text
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty());
    let (_, header) = lines.next().ok_or_else(|| format!("{file}: empty file"))?;
    let names: Vec<&str> = header.split(',').map(str::trim).collect();
    let col = |name: &str| names.iter().position(|n| *n == name);
    let need = |name: &str| {
        col(name).ok_or_else(|| format!("{file}: line 1: no `{name}` column (header: {header})"))
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
        if fields.len() != names.len() {
            return Err(format!(
                "{file}: line {}: {} fields, the header has {}",
                n + 1,
                fields.len(),
                names.len()
            ));
        }
        let num = |i: usize| -> Result<f64, String> {
            let v: f64 = fields[i].parse().map_err(|_| {
                format!(
                    "{file}: line {}: column `{}`: `{}` is not a number",
                    n + 1,
                    names[i],
                    fields[i]
                )
            })?;
            if v.is_finite() {
                Ok(v)
            } else {
                Err(format!(
                    "{file}: line {}: column `{}`: {v} is not finite",
                    n + 1,
                    names[i]
                ))
            }
        };
        let t = num(it)?;
        if let Some(&prev) = log.t.last() {
            if t <= prev {
                return Err(format!(
                    "{file}: line {}: column `t_s`: time {t} does not increase",
                    n + 1
                ));
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
        return Err(format!(
            "{file}: {} samples: at least 100 (0.1 s at 1 kHz) are needed",
            log.t.len()
        ));
    }
    let dt = log.t[1] - log.t[0];
    if let Some(k) = log
        .t
        .windows(2)
        .position(|w| ((w[1] - w[0]) - dt).abs() > 1e-3 * dt)
    {
        return Err(format!(
            "{file}: line {}: column `t_s`: the sample period changes (uniform sampling needed)",
            k + 3
        ));
    }
    if *log.t.last().unwrap_or(&0.0) < 0.6 - 1e-9 {
        return Err(format!(
            "{file}: the log ends before 0.6 s: the four steps need 0..0.6 s"
        ));
    }
    Ok(log)
}

/// The fitted quantities, in the order the steps use them.
const NAMES: [&str; 6] = [
    "jm_kgm2",
    "density_kg_m3",
    "ei_nm2",
    "viscous_nms",
    "coulomb_nm",
    "root_gauge_m",
];

fn get(p: &BeamParams, i: usize) -> f64 {
    [
        p.jm_kgm2,
        p.density_kg_m3,
        p.ei_nm2,
        p.viscous_nms,
        p.coulomb_nm,
        p.root_gauge_m,
    ][i]
}

fn set(p: &mut BeamParams, i: usize, v: f64) {
    *[
        &mut p.jm_kgm2,
        &mut p.density_kg_m3,
        &mut p.ei_nm2,
        &mut p.viscous_nms,
        &mut p.coulomb_nm,
        &mut p.root_gauge_m,
    ][i] = v;
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

/// Fits `which` parameters of `p` within `bounds` to minimise the step's error.
fn fit_step<const N: usize>(
    p: &mut BeamParams,
    log: &Log,
    which: &[(usize, f64, f64, bool)],
    fit: Fit,
    evals: usize,
) {
    let params: Vec<Param> = which
        .iter()
        .map(|&(i, lo, hi, log)| Param {
            name: NAMES[i],
            lo,
            hi,
            log,
        })
        .collect();
    let start = start_of(p, which, &params);
    let base = *p;
    let at = |u: &[f64]| {
        let mut q = base;
        for ((&(i, ..), par), &u) in which.iter().zip(&params).zip(u) {
            set(&mut q, i, par.gain_at(u));
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
        .unwrap_or_else(|| start_of(p, which, &params));
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
) -> Result<(BeamParams, Vec<StepReport>), String> {
    Beam::try_build(*guess).map_err(|e| e.to_string())?;
    let mut p = *guess;
    let mut reports = Vec::new();
    let wide = |v: f64| (v / 2.0, v * 2.0, true);
    let friction_bounds = |v: f64, floor: f64| (0.0, (4.0 * v).max(floor), false);
    let mut report =
        |name, fit: Fit, which: &[(usize, f64, f64, bool)], p: &BeamParams| -> Result<(), String> {
            let (et, es, _) = fit_error::<N>(p, log, fit)
                .ok_or_else(|| format!("step `{name}`: the model broke down on this log"))?;
            reports.push(StepReport {
                name,
                window: fit.window,
                fitted: which.iter().map(|&(i, ..)| (NAMES[i], get(p, i))).collect(),
                rms_theta_err_rad: et,
                rms_strain_err_ue: es,
            });
            Ok(())
        };
    let t_end = (log.t[log.t.len() - 1] - log.t[0]).min(0.6);
    // 1. Mass and stiffness, on the hub angle during the move.
    let fit1 = Fit {
        window: (0.0, 0.35),
        w1: 1.0,
        w2: 0.0,
    };
    let s1: Vec<_> = [0, 1, 2]
        .iter()
        .map(|&i| {
            let (lo, hi, l) = wide(get(&p, i));
            (i, lo, hi, l)
        })
        .collect();
    fit_step::<N>(&mut p, log, &s1, fit1, evals);
    report("mass and stiffness", fit1, &s1, &p)?;
    // 2. Friction, after the move.
    let fit2 = Fit {
        window: (0.35, t_end),
        w1: 1.0,
        w2: 0.0,
    };
    let s2 = [
        {
            let (lo, hi, l) = friction_bounds(p.viscous_nms, 1e-3);
            (3, lo, hi, l)
        },
        {
            let (lo, hi, l) = friction_bounds(p.coulomb_nm, 0.05);
            (4, lo, hi, l)
        },
    ];
    fit_step::<N>(&mut p, log, &s2, fit2, evals);
    report("friction", fit2, &s2, &p)?;
    // 3. All of them, within +-20 % of steps 1-2.
    let fit3 = Fit {
        window: (0.0, t_end),
        w1: 1.0,
        w2: 0.0,
    };
    let s3: Vec<_> = (0..5)
        .map(|i| {
            let v = get(&p, i);
            if i >= 3 {
                (i, 0.8 * v, (1.2 * v).max(1e-6), false)
            } else {
                (i, 0.8 * v, 1.2 * v, true)
            }
        })
        .collect();
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
        (5, 0.0, 0.2 * p.length_m, false),
        (1, 0.8 * p.density_kg_m3, 1.2 * p.density_kg_m3, true),
        (2, 0.8 * p.ei_nm2, 1.2 * p.ei_nm2, true),
    ];
    fit_step::<N>(&mut p, log, &s4, fit4, evals);
    report("strain side", fit4, &s4, &p)?;
    Ok((p, reports))
}
