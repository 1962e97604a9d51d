//! Gain design by constrained optimisation of the paper's cost J (docs/design.md, section 5).
//!
//! Two stages, both deterministic for a seed: a Latin-hypercube sample of the gain bounds,
//! evaluated in parallel (rayon keeps the results in sample order) and, with
//! [`Search::Evolution`], evolved from there by differential evolution, then COBYLA (the `cobyla`
//! crate, a pure-Rust translation of NLopt's; chosen because it takes inequality constraints
//! without gradients, and the closed loop is not differentiable: counts are quantised and the
//! switching function may be `sign`) from the best few samples. Gains are searched in a unit
//! cube mapped to log scale for the positive gains and linearly for the strain blend c.
//!
//! Constraints G(x) <= 0: the commanded torque stays below the drive limit (a saturated drive
//! is not running the designed law), no validity-guard breakdown, no latched fault, and,
//! optionally, the hub within a given angle of the target at 0.6 s.

use beam_sim::metrics::{cost, metrics, metrics_with, CostSpec, Metrics, SettleSpec};
use beam_sim::sim::Motion;
use beam_sim::sim::{simulate, simulate_mismatched, SimError, SimOptions, SimResult};
use model_core::{Beam, BeamParams, Law, LawKind, ModalModel, Switching};
use rand::{rngs::StdRng, Rng, SeedableRng};
use rayon::prelude::*;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;

pub use crate::fit::{latin_hypercube, Param};

/// Bounds of the strain blend c on `model`: where the blended output keeps its control
/// direction, `1 - c gamma >= 0.25`, and within +-2000.
fn blend_bounds<const N: usize>(model: &ModalModel<N>) -> (f64, f64) {
    let gamma = model_core::law::strain_coupling(model) as f64;
    // 1 - c gamma >= 0.25 on the side where c gamma > 0.
    let edge = 0.75 / gamma.abs().max(1e-12);
    let (lo, hi) = if gamma > 0.0 {
        (-4.0 * edge, edge)
    } else {
        (-edge, 4.0 * edge)
    };
    (lo.max(-2000.0), hi.min(2000.0))
}

/// Default search bounds for `kind` on `model`, from the law's gain specs
/// ([`LawKind::gains`]): log-uniform within their ranges, and c where the blended output
/// keeps its control direction, `1 - c gamma >= 0.25`.
pub fn default_params<const N: usize>(kind: LawKind, model: &ModalModel<N>) -> Vec<Param> {
    kind.gains()
        .map(|g| {
            let ((lo, hi), log) = match g.search {
                model_core::law::Search::Log(lo, hi) => ((lo, hi), true),
                model_core::law::Search::Blend => (blend_bounds(model), false),
            };
            Param {
                name: g.name,
                lo,
                hi,
                log,
            }
        })
        .collect()
}

/// The hold test: `nm` on the hub from `at_s` to `until_s` (s after the move starts, the hub
/// at rest at the target); the hub may move at most `max_dev_deg` while loaded and must be
/// back within 0.1 deg `recover_s` after the load is removed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LoadHold {
    /// Load torque, N m.
    pub nm: f64,
    /// Applied at, s.
    pub at_s: f64,
    /// Removed at, s.
    pub until_s: f64,
    /// Largest hub deviation allowed while loaded, deg.
    pub max_dev_deg: f64,
    /// Longest recovery allowed after removal, s.
    pub recover_s: f64,
}

impl LoadHold {
    /// The hold test (docs/design.md, section 5): 0.5 N m on the hub from 1.0 s to
    /// 1.5 s, at most 1 deg off, back within 0.3 s.
    pub const DEFAULT: LoadHold = LoadHold {
        nm: 0.5,
        at_s: 1.0,
        until_s: 1.5,
        max_dev_deg: 1.0,
        recover_s: 0.3,
    };

    /// The run's fault injection for this test.
    pub fn injection(&self) -> beam_sim::sim::Injection {
        beam_sim::sim::Injection {
            kind: beam_sim::sim::FaultKind::LoadTorque {
                nm: self.nm,
                for_s: self.until_s - self.at_s,
            },
            at_s: self.at_s,
        }
    }

    /// How far `m` (metrics of a run with this load) is from passing: <= 0 passes.
    pub fn violation(&self, m: &Metrics) -> f64 {
        let dev = m
            .hold_max_dev_deg
            .map_or(1e3, |d| d / self.max_dev_deg - 1.0);
        let rec = match m.hold_recover_s {
            Some(Some(r)) => r / self.recover_s - 1.0,
            _ => 1e3,
        };
        dev.max(rec)
    }
}

/// One plant and move of a robust design. The drive's law is built on the nominal model (at
/// the nominal payload); the plant is this one.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Scenario {
    /// The plant's parameters.
    pub plant: BeamParams,
    /// The move (its shaper's frequency and damping are replaced by the searched ones).
    pub motion: Motion,
}

/// The `q` quantile of `values` (linear interpolation between order statistics); NaN for
/// none. Infinite values count as the largest.
pub fn quantile(values: &mut [f64], q: f64) -> f64 {
    if values.is_empty() {
        return f64::NAN;
    }
    values.sort_by(|a, b| a.total_cmp(b));
    let pos = q.clamp(0.0, 1.0) * (values.len() - 1) as f64;
    let (lo, hi) = (pos.floor() as usize, pos.ceil() as usize);
    let f = pos - lo as f64;
    if f == 0.0 || !values[hi].is_finite() {
        values[if f == 0.0 { lo } else { hi }]
    } else {
        values[lo] + f * (values[hi] - values[lo])
    }
}

/// The name of the searched shaper frequency among a spec's parameters.
pub const SHAPER_HZ: &str = "shaper_hz";
/// The name of the searched shaper damping ratio among a spec's parameters.
pub const SHAPER_DAMPING: &str = "shaper_damping";

/// What to optimise and how hard.
#[derive(Clone, Debug, PartialEq)]
pub struct Spec {
    /// The controller.
    pub kind: LawKind,
    /// The drive's instruments: the simulated sensors, and what an observer law is designed
    /// on (the rig's, from its gain table's `[drive]`).
    pub instruments: model_core::Instruments,
    /// Searched gains and bounds.
    pub params: Vec<Param>,
    /// Switching function (SMC).
    pub switching: Switching,
    /// The move designed for, with its shaper (whose frequency is searched as `shaper_hz`
    /// when the params include it).
    pub motion: Motion,
    /// Keep the model terms (smc-strain).
    pub model_terms: bool,
    /// Cost weights, windows and units.
    pub cost: CostSpec,
    /// Constraint: |theta - theta_final| at 0.6 s at most this, deg.
    pub max_err_deg_0_6: Option<f64>,
    /// Constraint: |theta - theta_final| at most `.1` deg at time `.0` s (and the run lasts that
    /// long). J looks only to 0.6 s; without this, gains that stop the beam but let the hub
    /// creep toward the target for seconds score well.
    pub hold: Option<(f64, f64)>,
    /// Constraint: a step load applied at rest after the move is held and recovered from.
    pub load_hold: Option<LoadHold>,
    /// Robust design: the plants and moves every candidate runs on (the same set for every
    /// candidate: common random numbers). Empty: the nominal plant and `motion` only.
    pub scenarios: Vec<Scenario>,
    /// Robust design: the quantile of J over the scenarios that is minimised (0.95: p95).
    pub quantile: f64,
    /// Constraint: peak commanded torque at most this fraction of the drive limit.
    pub torque_fraction: f64,
    /// Constraint: the true root strain at most this, ue, over the whole run (the move
    /// included); `None`: not constrained (the drive's over-strain trip still is).
    pub max_root_strain_ue: Option<f64>,
    /// Latin-hypercube samples of the global stage (with [`Search::Evolution`], the
    /// population).
    pub samples: usize,
    /// The global stage: the sample alone, or differential evolution from it.
    pub search: Search,
    /// Local COBYLA runs, from the best samples.
    pub starts: usize,
    /// Objective evaluations per local run.
    pub local_evals: usize,
    /// Seed of the sample (and of the simulated sensor noise).
    pub seed: u64,
    /// Gains (in `params` order) to start one local run from, for instance the neighbouring
    /// payload's row: rows found from a common start stay in one region of gain space, so
    /// interpolating between them stays meaningful.
    pub warm_start: Option<Vec<f64>>,
    /// What is minimised: J (`cost`), or the settle time from the move command.
    pub objective: Objective,
}

/// What the optimiser minimises.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Objective {
    /// The paper's J, on windows from the move's end.
    Cost,
    /// The settle time from the move command (hub and strain bands), on a run of
    /// [`SETTLE_RUN_S`] without the load test (which, when asked for, runs separately); a
    /// run that has not settled by its end scores twice its length. Constraint: the torque's
    /// RMS over the run's last 0.5 s at most [`QUIET_TORQUE_RMS_NM`].
    Settle(SettleSpec),
}

/// The global stage of the search.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Search {
    /// The Latin-hypercube sample, whose best points start the local runs: cheap, but what it
    /// finds depends on where the sample happened to land.
    Sampled,
    /// Differential evolution ([`differential_evolution`]) for this many generations, its
    /// first population the Latin-hypercube sample; the local runs start from its best.
    Evolution {
        /// Generations after the first population.
        generations: usize,
    },
}

impl Search {
    /// Closed-loop evaluations of the global stage with a population of `samples`.
    pub fn evaluations(&self, samples: usize) -> usize {
        match *self {
            Search::Sampled => samples,
            Search::Evolution { generations } => samples * (generations + 1),
        }
    }
}

/// How long a settle-time evaluation simulates, s.
pub const SETTLE_RUN_S: f64 = 3.0;

/// Largest torque RMS at rest a settle-time design may leave, N m (the bound of the shipped
/// rows' quiet test).
pub const QUIET_TORQUE_RMS_NM: f64 = 0.5;

/// One evaluated gain set.
#[derive(Clone, Debug, PartialEq)]
pub struct Evaluation {
    /// The gains, in the order of `Spec::params`.
    pub gains: Vec<f64>,
    /// The law they make.
    pub law: Law,
    /// J (infinite when the run broke down).
    pub cost: f64,
    /// The angle term W1 int e1^2.
    pub angle_term: f64,
    /// The strain term W2 int e2^2.
    pub strain_term: f64,
    /// Worst constraint value: feasible when <= 0.
    pub violation: f64,
}

impl Evaluation {
    /// Gains `x` whose run broke down, faulted or could not start: infinitely costly and far
    /// outside the constraints.
    fn failed(x: &[f64], law: Law) -> Self {
        Self {
            gains: x.to_vec(),
            law,
            cost: f64::INFINITY,
            angle_term: f64::INFINITY,
            strain_term: f64::INFINITY,
            violation: 1e3,
        }
    }

    /// True when every constraint holds.
    pub fn feasible(&self) -> bool {
        self.violation <= 0.0 && self.cost.is_finite()
    }

    /// Ranking key: feasible first by cost, then infeasible by violation.
    fn rank(&self) -> (bool, f64) {
        if self.feasible() {
            (false, self.cost)
        } else {
            (true, self.violation)
        }
    }
}

/// The result of a design.
#[derive(Clone, Debug)]
pub struct Outcome {
    /// The best gain set found.
    pub best: Evaluation,
    /// Closed-loop evaluations run.
    pub evaluations: usize,
}

/// The law for gains `x` (in `spec.params` order): each of the law's gains by its name,
/// the law's starting gains ([`Law::start`]) for any the spec does not search.
pub fn law_of(spec: &Spec, x: &[f64]) -> Law {
    let kind = spec.kind;
    let mut values = Law::start(kind).values();
    for (v, name) in values.iter_mut().zip(kind.gain_names()) {
        if let Some(i) = spec.params.iter().position(|p| p.name == *name) {
            *v = x[i] as f32;
        }
    }
    let settings = model_core::Settings {
        switching: spec.switching,
        model_terms: spec.model_terms,
    };
    Law::from_values(kind, values, settings)
}

/// The move for gains `x`: the spec's move, with the shaper's frequency taken from the
/// `shaper_hz` parameter when it is searched.
pub fn motion_for(spec: &Spec, x: &[f64]) -> Motion {
    let mut m = spec.motion;
    if let Some(i) = spec.params.iter().position(|p| p.name == SHAPER_HZ) {
        m.shaper.freq_hz = x[i] as f32;
    }
    if let Some(i) = spec.params.iter().position(|p| p.name == SHAPER_DAMPING) {
        m.shaper.damping = x[i] as f32;
    }
    m
}

/// Simulated time a cost evaluation needs: the end of the later window (at least 0.6 s for
/// the hub-error constraint).
fn eval_duration(spec: &Spec) -> f64 {
    let hold = spec.hold.map_or(0.0, |h| h.0).max(
        spec.load_hold
            .map_or(0.0, |h| h.until_s + h.recover_s + 0.2),
    );
    // A stretched shaped move ends up to a shaper's length (below a second) later.
    let later = match spec.motion.timing {
        model_core::Timing::Stretch if spec.motion.shaper.kind != model_core::ShaperKind::None => {
            1.0
        }
        _ => 0.0,
    };
    spec.cost
        .angle_window
        .1
        .max(spec.cost.strain_window.1)
        .max(0.6)
        .max(hold)
        + later
}

/// Runs the closed loop for gains `x` and scores it: on the nominal plant, or over the
/// spec's scenarios (robust design).
pub fn evaluate<const N: usize>(model: &ModalModel<N>, spec: &Spec, x: &[f64]) -> Evaluation {
    if spec.scenarios.is_empty() {
        evaluate_nominal(model, spec, x)
    } else {
        evaluate_robust(model, spec, x)
    }
}

/// Robust score: the spec's quantile of J over the scenarios; constraints: peak torque in
/// every scenario, the hub error at the move's end + 0.25 s at that quantile, and the load
/// test in every scenario.
fn evaluate_robust<const N: usize>(model: &ModalModel<N>, spec: &Spec, x: &[f64]) -> Evaluation {
    let law = law_of(spec, x);
    let searched = motion_for(spec, x).shaper;
    let runs: Vec<Option<Evaluation>> = spec
        .scenarios
        .par_iter()
        .map(|sc| {
            let plant = ModalModel::<N>::try_build(&Beam::try_build(sc.plant).ok()?).ok()?;
            let mut motion = sc.motion;
            if motion.shaper.kind != model_core::ShaperKind::None {
                motion.shaper.freq_hz = searched.freq_hz;
                motion.shaper.damping = searched.damping;
            }
            run_case(&plant, model, spec, x, law, motion)
        })
        .collect();
    let Some(runs) = runs.into_iter().collect::<Option<Vec<Evaluation>>>() else {
        return Evaluation::failed(x, law);
    };
    let q = |f: fn(&Evaluation) -> f64| {
        quantile(&mut runs.iter().map(f).collect::<Vec<_>>(), spec.quantile)
    };
    Evaluation {
        gains: x.to_vec(),
        law,
        cost: q(|e| e.cost),
        angle_term: q(|e| e.angle_term),
        strain_term: q(|e| e.strain_term),
        // Each scenario's violation already combines torque, hub error and load test; the
        // torque and load parts must hold everywhere, so take the worst.
        violation: runs
            .iter()
            .map(|e| e.violation)
            .fold(f64::NEG_INFINITY, f64::max),
    }
}

/// Runs the closed loop for gains `x` on the nominal plant and scores it.
fn evaluate_nominal<const N: usize>(model: &ModalModel<N>, spec: &Spec, x: &[f64]) -> Evaluation {
    let law = law_of(spec, x);
    run_case(model, model, spec, x, law, motion_for(spec, x))
        .unwrap_or_else(|| Evaluation::failed(x, law))
}

/// One case: `law` designed on `nominal` against `plant` over `motion`, scored by the spec's
/// objective; `None` when a run breaks down, faults or cannot start.
fn run_case<const N: usize>(
    plant: &ModalModel<N>,
    nominal: &ModalModel<N>,
    spec: &Spec,
    x: &[f64],
    law: Law,
    motion: Motion,
) -> Option<Evaluation> {
    let opts = SimOptions {
        duration_s: eval_duration(spec),
        motion,
        fault: spec.load_hold.map(|h| h.injection()),
        sensors: beam_sim::sensors::SensorConfig {
            seed: spec.seed,
            ..beam_sim::sensors::SensorConfig::reading(spec.instruments)
        },
        ..SimOptions::default()
    };
    match spec.objective {
        Objective::Cost => {
            let run = simulate_mismatched(plant, nominal, law, &opts).ok()?;
            score(plant, spec, x, law, &run, true)
        }
        Objective::Settle(bands) => {
            // The move alone, long enough to settle; the load test on its own run.
            let quiet = SimOptions {
                duration_s: SETTLE_RUN_S.max(opts.duration_s),
                fault: None,
                ..opts
            };
            let run = simulate_mismatched(plant, nominal, law, &quiet).ok()?;
            let mut e = score(plant, spec, x, law, &run, false)?;
            if let Some(h) = spec.load_hold {
                let loaded = simulate_mismatched(plant, nominal, law, &opts).ok()?;
                if loaded.breakdown.is_some() || !loaded.faults.is_empty() {
                    return None;
                }
                e.violation = e.violation.max(h.violation(&metrics(&loaded)));
            }
            // Quiet at rest as well as settled: the torque's RMS over the run's last half
            // second at most QUIET_TORQUE_RMS_NM (an observer that trusts its sensors too
            // much settles fast and then hums).
            let tail: Vec<f64> = run
                .samples
                .iter()
                .filter(|s| s.t >= quiet.duration_s - 0.5)
                .map(|s| s.torque * s.torque)
                .collect();
            let rms = (tail.iter().sum::<f64>() / tail.len().max(1) as f64).sqrt();
            e.violation = e.violation.max(rms / QUIET_TORQUE_RMS_NM - 1.0);
            let settle = metrics_with(&run, &bands).settle_s;
            e.cost = settle.unwrap_or(2.0 * quiet.duration_s);
            Some(e)
        }
    }
}

/// J and the constraints of one run; the load test only if `with_load` (the run carried it).
fn score<const N: usize>(
    model: &ModalModel<N>,
    spec: &Spec,
    x: &[f64],
    law: Law,
    run: &SimResult,
    with_load: bool,
) -> Option<Evaluation> {
    if run.breakdown.is_some() || !run.faults.is_empty() {
        return None;
    }
    let limit = model.beam.params().torque_limit_nm;
    let peak = run
        .samples
        .iter()
        .map(|s| s.torque.abs())
        .fold(0.0, f64::max);
    let mut violation = peak / (spec.torque_fraction * limit) - 1.0;
    if let Some(max_ue) = spec.max_root_strain_ue {
        let strain = run
            .samples
            .iter()
            .map(|s| s.root_strain.abs())
            .fold(0.0, f64::max);
        violation = violation.max(1e6 * strain / max_ue - 1.0);
    }
    let err_at = |t: f64| {
        let k = run.samples.iter().position(|s| s.t >= t - 1e-9)?;
        Some((run.samples[k].theta - run.theta_final).abs().to_degrees())
    };
    // Times are the paper's, kept relative to the move's end for a move that ends later.
    let dt = run.move_end_s - beam_sim::sim::SLEW_TIME_S;
    if let Some(max_err) = spec.max_err_deg_0_6 {
        violation = violation.max(err_at(0.6 + dt)? / max_err - 1.0);
    }
    if let Some((t, max_err)) = spec.hold {
        violation = violation.max(err_at(t + dt)? / max_err - 1.0);
    }
    if let Some(h) = spec.load_hold.filter(|_| with_load) {
        violation = violation.max(h.violation(&metrics(run)));
    }
    let windows = spec.cost.shifted(dt);
    let angle_term = cost(run, &CostSpec { w2: 0.0, ..windows });
    let strain_term = cost(run, &CostSpec { w1: 0.0, ..windows });
    Some(Evaluation {
        gains: x.to_vec(),
        law,
        cost: angle_term + strain_term,
        angle_term,
        strain_term,
        violation,
    })
}

/// Differential evolution (Storn and Price's DE/rand/1/bin) in the unit cube, from the
/// population `init`, for `generations` generations; returns the last population with each
/// member's evaluation.
///
/// Each generation, every member `x_i` meets a trial: three other members `a, b, c` drawn at
/// random give the mutant `a + F (b - c)`, with F drawn once a generation from 0.5-1
/// (dither), crossed with `x_i` coordinate by coordinate at rate 0.9 (one coordinate always
/// from the mutant); a coordinate the mutant takes outside 0-1 is drawn between `a`'s and that
/// bound. The trial replaces `x_i` when it ranks no worse by `rank` (lower is better; the
/// optimiser's rank puts every feasible point before every infeasible one, then orders by
/// cost or by violation: Deb's rules for constraints). Trials are drawn from one seeded
/// generator before they are evaluated, in parallel, so the result depends on the seed alone.
/// A population of fewer than four is returned evaluated but not evolved.
///
/// Written here rather than taken from a crate: the one permissively licensed DE crate is
/// unmaintained (2016), evaluates serially and takes neither constraints nor a seed.
pub fn differential_evolution<E: Send>(
    init: Vec<Vec<f64>>,
    generations: usize,
    seed: u64,
    eval: &(dyn Fn(&[f64]) -> E + Sync),
    rank: &dyn Fn(&E) -> (bool, f64),
) -> Vec<(Vec<f64>, E)> {
    const CROSSOVER: f64 = 0.9;
    let mut rng = StdRng::seed_from_u64(seed);
    let mut pop: Vec<(Vec<f64>, E)> = init
        .into_par_iter()
        .map(|u| {
            let e = eval(&u);
            (u, e)
        })
        .collect();
    let n = pop.len();
    if n < 4 {
        return pop;
    }
    for _ in 0..generations {
        let f = 0.5 + 0.5 * rng.gen::<f64>();
        let trials: Vec<Vec<f64>> = (0..n)
            .map(|i| {
                let mut pick = |avoid: &[usize]| loop {
                    let k = rng.gen_range(0..n);
                    if !avoid.contains(&k) {
                        break k;
                    }
                };
                let a = pick(&[i]);
                let b = pick(&[i, a]);
                let c = pick(&[i, a, b]);
                let x = &pop[i].0;
                let forced = rng.gen_range(0..x.len().max(1));
                (0..x.len())
                    .map(|j| {
                        if j != forced && rng.gen::<f64>() >= CROSSOVER {
                            return x[j];
                        }
                        let base = pop[a].0[j];
                        let v = base + f * (pop[b].0[j] - pop[c].0[j]);
                        if v < 0.0 {
                            base * rng.gen::<f64>()
                        } else if v > 1.0 {
                            base + (1.0 - base) * rng.gen::<f64>()
                        } else {
                            v
                        }
                    })
                    .collect()
            })
            .collect();
        let evaluated: Vec<E> = trials.par_iter().map(|u| eval(u)).collect();
        for (member, (u, e)) in pop.iter_mut().zip(trials.into_iter().zip(evaluated)) {
            if matches!(
                rank(&e).partial_cmp(&rank(&member.1)),
                Some(std::cmp::Ordering::Less | std::cmp::Ordering::Equal)
            ) {
                *member = (u, e);
            }
        }
    }
    pop
}

/// Designs gains for `model` per `spec`. `progress(done, total)` is called as evaluations
/// finish (from several threads).
pub fn optimize<const N: usize>(
    model: &ModalModel<N>,
    spec: &Spec,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Outcome {
    let d = spec.params.len();
    let total = spec.search.evaluations(spec.samples) + spec.starts * spec.local_evals;
    let done = AtomicUsize::new(0);
    let tick = || progress(done.fetch_add(1, Ordering::Relaxed) + 1, total);

    // Stage 1: Latin hypercube, evolved when asked.
    let units = latin_hypercube(spec.samples, d, spec.seed);
    let to_gains = |u: &[f64]| {
        spec.params
            .iter()
            .zip(u)
            .map(|(p, &u)| p.gain_at(u))
            .collect::<Vec<f64>>()
    };
    let eval_unit = |u: &[f64]| {
        let e = evaluate(model, spec, &to_gains(u));
        tick();
        e
    };
    let mut sampled: Vec<(Vec<f64>, Evaluation)> = match spec.search {
        Search::Sampled => units
            .par_iter()
            .map(|u| (u.clone(), eval_unit(u)))
            .collect(),
        Search::Evolution { generations } => differential_evolution(
            units,
            generations,
            spec.seed ^ 0xDE,
            &eval_unit,
            &Evaluation::rank,
        ),
    };
    sampled.sort_by(|a, b| {
        a.1.rank()
            .partial_cmp(&b.1.rank())
            .unwrap_or(std::cmp::Ordering::Equal)
    });

    // Stage 2: COBYLA from the warm start and the best samples, in parallel.
    let warm = spec.warm_start.as_ref().filter(|g| g.len() == d).map(|g| {
        let u: Vec<f64> = spec
            .params
            .iter()
            .zip(g)
            .map(|(p, &x)| p.unit_of(x))
            .collect();
        let e = evaluate(model, spec, &to_gains(&u));
        (u, e)
    });
    let take = spec.starts.saturating_sub(usize::from(warm.is_some()));
    let starts: Vec<&(Vec<f64>, Evaluation)> =
        warm.iter().chain(sampled.iter().take(take)).collect();
    let local: Vec<Evaluation> = starts
        .par_iter()
        .map(|(u0, e0)| {
            let best = Mutex::new(e0.clone());
            let last: Mutex<Option<(Vec<f64>, Evaluation)>> = Mutex::new(None);
            // COBYLA asks for the objective and each constraint at the same point: run the
            // closed loop once per point.
            let eval_at = |u: &[f64]| -> Evaluation {
                let mut cache = last.lock().unwrap_or_else(|p| p.into_inner());
                if let Some((cu, ce)) = cache.as_ref() {
                    if cu.as_slice() == u {
                        return ce.clone();
                    }
                }
                let e = evaluate(model, spec, &to_gains(u));
                tick();
                let mut b = best.lock().unwrap_or_else(|p| p.into_inner());
                if e.rank().partial_cmp(&b.rank()) == Some(std::cmp::Ordering::Less) {
                    *b = e.clone();
                }
                *cache = Some((u.to_vec(), e.clone()));
                e
            };
            // Objective: log J (J spans decades), a large finite value where the run fails.
            let objective = |u: &[f64], _: &mut ()| {
                let e = eval_at(u);
                if e.cost.is_finite() {
                    e.cost.max(1e-300).ln()
                } else {
                    1e3
                }
            };
            // cobyla's constraints are c(x) >= 0: pass -G(x).
            let constraint = |u: &[f64], _: &mut ()| -eval_at(u).violation;
            let cons: [&dyn cobyla::Func<()>; 1] = [&constraint];
            let bounds = vec![(0.0, 1.0); d];
            let _ = cobyla::minimize(
                objective,
                u0,
                &bounds,
                &cons,
                (),
                spec.local_evals,
                cobyla::RhoBeg::All(0.05),
                Some(cobyla::StopTols {
                    xtol_rel: 1e-4,
                    ..Default::default()
                }),
            );
            best.into_inner().unwrap_or_else(|p| p.into_inner())
        })
        .collect();
    let best = local
        .into_iter()
        .chain(sampled.first().map(|s| s.1.clone()))
        .min_by(|a, b| {
            a.rank()
                .partial_cmp(&b.rank())
                .unwrap_or(std::cmp::Ordering::Equal)
        })
        .unwrap_or_else(|| evaluate(model, spec, &to_gains(&vec![0.5; d])));
    Outcome {
        best,
        evaluations: done.load(Ordering::Relaxed),
    }
}

/// Full-length metrics of `law` on `model` running `motion` (for reporting a design against
/// the baseline), with the load test's load when given.
pub fn full_metrics<const N: usize>(
    model: &ModalModel<N>,
    law: Law,
    instruments: model_core::Instruments,
    seed: u64,
    motion: Motion,
    load: Option<LoadHold>,
) -> Result<Metrics, SimError> {
    let opts = SimOptions {
        sensors: beam_sim::sensors::SensorConfig {
            seed,
            ..beam_sim::sensors::SensorConfig::reading(instruments)
        },
        motion,
        duration_s: FULL_RUN_S,
        ..SimOptions::default()
    };
    // The move without a load, long enough for its settle time; the hold figures from a run
    // with the load (which would otherwise disturb the settle time it is not about).
    let mut m = simulate(model, law, &opts).map(|r| metrics(&r))?;
    if let Some(h) = load {
        let held = simulate(
            model,
            law,
            &SimOptions {
                fault: Some(h.injection()),
                ..opts
            },
        )
        .map(|r| metrics(&r))?;
        m.hold_max_dev_deg = held.hold_max_dev_deg;
        m.hold_recover_s = held.hold_recover_s;
    }
    Ok(m)
}

/// How long [`full_metrics`] simulates, s: settle times of a few seconds show.
pub const FULL_RUN_S: f64 = 4.0;

#[cfg(test)]
mod tests {
    use super::*;

    /// Rastrigin's function on the unit cube, its global minimum (0) moved off the centre to
    /// `u = 3 / 10.24` in every coordinate; every other local minimum is at least 1.
    fn rastrigin(u: &[f64]) -> f64 {
        u.iter()
            .map(|&u| {
                let z = 10.24 * u - 3.0;
                z * z - 10.0 * (2.0 * std::f64::consts::PI * z).cos() + 10.0
            })
            .sum()
    }

    fn best(pop: &[(Vec<f64>, (bool, f64))]) -> &(Vec<f64>, (bool, f64)) {
        pop.iter()
            .min_by(|a, b| a.1.partial_cmp(&b.1).unwrap())
            .unwrap()
    }

    #[test]
    fn evolution_finds_rastrigins_global_minimum_for_every_seed() {
        // 4 dimensions hold 11^4 local minima in the cube; a 40-point sample lands in the
        // global one's basin by luck alone.
        for seed in 0..4 {
            let init = latin_hypercube(40, 4, seed);
            let eval = |u: &[f64]| (false, rastrigin(u));
            let rank = |e: &(bool, f64)| *e;
            let sampled = best(
                &init
                    .iter()
                    .map(|u| (u.clone(), eval(u)))
                    .collect::<Vec<_>>(),
            )
            .1
             .1;
            let pop = differential_evolution(init, 300, seed, &eval, &rank);
            let (u, (_, f)) = best(&pop);
            assert!(
                *f < 0.5,
                "seed {seed}: {f} at {u:?} (sample's best {sampled})"
            );
            for x in u {
                assert!((x - 3.0 / 10.24).abs() < 0.01, "seed {seed}: {u:?}");
            }
        }
    }

    #[test]
    fn evolution_keeps_to_the_constraints_and_repeats_for_a_seed() {
        // Minimise x0 subject to x0 + x1 >= 1.2: the optimum is x0 = 0.2, x1 = 1, on the
        // constraint's edge; infeasible points rank by their violation.
        let eval = |u: &[f64]| {
            let violation = 1.2 - u[0] - u[1];
            if violation > 0.0 {
                (true, violation)
            } else {
                (false, u[0])
            }
        };
        let rank = |e: &(bool, f64)| *e;
        let run = || differential_evolution(latin_hypercube(20, 2, 7), 150, 7, &eval, &rank);
        let pop = run();
        let (u, (infeasible, f)) = best(&pop);
        assert!(!infeasible, "{u:?}");
        assert!((f - 0.2).abs() < 0.01 && u[1] > 0.99, "{u:?}");
        for (u, _) in &pop {
            assert!(u.iter().all(|x| (0.0..=1.0).contains(x)), "{u:?}");
        }
        assert_eq!(pop, run());
    }
}
