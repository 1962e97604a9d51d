//! Monte Carlo robustness: the controller, designed on the nominal model, against plants whose
//! parameters are off by up to +-spread and which carry a random payload (known to the drive,
//! which schedules its gains on it). Every case also runs the PD baseline, so the two are
//! compared on the same beams. Cases run in parallel; each has its own seeded generator, so
//! the result does not depend on the thread count.

use beam_sim::metrics::{metrics_with, Metrics, SettleSpec};
use beam_sim::sensors::SensorConfig;
use beam_sim::sim::{simulate_knowing, Known, Motion, SimError, SimOptions, SimResult};
use model_core::Instruments;
use model_core::{Beam, BeamParams, Law, ModalModel, Shaper, Timing};
use rand::{rngs::StdRng, Rng, SeedableRng};
use rayon::prelude::*;

/// How the cases are drawn.
#[derive(Clone, Debug, PartialEq)]
pub struct SweepSpec {
    /// Number of cases.
    pub cases: usize,
    /// Relative parameter error bound (0.2 = +-20 %).
    pub spread: f64,
    /// The modal damping ratio drawn log-uniformly from `(low, high)` (as many beams damped
    /// below the geometric middle as above it) instead of the nominal's within `spread`.
    /// `None`: within `spread`.
    pub damping_ratio: Option<(f64, f64)>,
    /// Largest payload, kg (drawn uniformly from 0).
    pub payload_max_kg: f64,
    /// Seed.
    pub seed: u64,
    /// Coulomb friction drawn uniformly from 0 to this, N m (0: the nominal's, scaled like
    /// the viscous friction).
    pub coulomb_max_nm: f64,
    /// Move amplitudes, deg, taken in turn by the cases, each at its planned time (empty:
    /// the paper's slew for every case).
    pub moves_deg: Vec<f64>,
    /// Plan each move (of `moves_deg`) with model-core's planner at the shortest time its
    /// limits allow, as a commanded drive does, rather than at [`planned_time_s`].
    pub shortest: bool,
    /// Plan the shortest moves to leave an observer law's reference beam at rest
    /// (`beam_sim::sim::Motion::exact`).
    pub exact: bool,
    /// Each move (of `moves_deg`) in this time, s, rather than at [`planned_time_s`] (shaped
    /// and stretched by the law's shaper, as `beam simulate --time S`).
    pub move_time_s: Option<f64>,
    /// Simulated time from the move command, s: long enough for the settle time to be seen.
    pub duration_s: f64,
    /// What counts as settled.
    pub settle: SettleSpec,
    /// The drive's instruments, which the simulated sensors are and the observer laws are
    /// designed on (a gain table's `[drive]`).
    pub instruments: Instruments,
    /// The simulated gauge's noise, strain (standard deviation; the observer laws are
    /// designed on their own assumption of it, whatever it is).
    pub strain_noise_std: f64,
    /// Feed the controller's observer law the true state ([`SimOptions::true_state`]).
    pub true_state: bool,
    /// The parts of each case's drive built on the drawn beam instead of the nominal one at
    /// the drawn payload (its laws' designs, its planner's inertia); where the reference is
    /// known, the shapers' frequencies are scaled by the drawn beam's first hub-free
    /// frequency against the nominal's: what identifying the beam could at most give.
    pub drive_knows: Known,
    /// Which of the drawn beam's parameters the beam those parts are built on carries (the
    /// rest the nominal beam's): what identifying only those could give.
    pub known_params: KnownParams,
}

/// Which of a drawn beam's parameters a drive that knows the beam ([`SweepSpec::drive_knows`])
/// is built with; the others are the nominal beam's, at the drawn payload (which the gain
/// table's rows already know).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct KnownParams {
    /// The beam's stiffness against its mass, `EI / rho`, as drawn, with the nominal density
    /// (EI scaled by the ratio): its frequencies with the hub clamped, what the observer
    /// laws' identifier finds. Taken over by `ei` and `density` where either is known.
    pub stiffness: bool,
    /// EI as drawn.
    pub ei: bool,
    /// The density as drawn.
    pub density: bool,
    /// The hub's inertia Jm as drawn.
    pub hub: bool,
    /// The beam's damping ratio as drawn.
    pub damping: bool,
    /// Viscous and Coulomb friction as drawn.
    pub friction: bool,
}

impl KnownParams {
    /// Every parameter as drawn: the drive built on the drawn beam itself.
    pub const ALL: Self = Self {
        stiffness: true,
        ei: true,
        density: true,
        hub: true,
        damping: true,
        friction: true,
    };

    /// The beam a drive built with these parameters of case `p` (drawn about `nominal`)
    /// knows.
    pub fn apply(&self, p: &Perturbation, nominal: &BeamParams) -> BeamParams {
        let drawn = p.apply(nominal);
        let at_payload = BeamParams {
            tip_mass_kg: p.payload_kg,
            ..*nominal
        };
        let pick = |known: bool, drawn: f64, nominal: f64| if known { drawn } else { nominal };
        let ei_nm2 = if self.ei || self.density {
            pick(self.ei, drawn.ei_nm2, nominal.ei_nm2)
        } else {
            pick(
                self.stiffness,
                nominal.ei_nm2 * p.ei / p.rho,
                nominal.ei_nm2,
            )
        };
        BeamParams {
            ei_nm2,
            density_kg_m3: pick(self.density, drawn.density_kg_m3, nominal.density_kg_m3),
            jm_kgm2: pick(self.hub, drawn.jm_kgm2, nominal.jm_kgm2),
            damping_ratio: pick(self.damping, drawn.damping_ratio, nominal.damping_ratio),
            viscous_nms: pick(self.friction, drawn.viscous_nms, nominal.viscous_nms),
            coulomb_nm: pick(self.friction, drawn.coulomb_nm, nominal.coulomb_nm),
            ..at_payload
        }
    }
}

/// The simulated time a sweep runs by default, s: settle times of several seconds are common
/// for laws that leave the beam to its own 1 % damping, and a run that ends first reports
/// "never".
pub const DEFAULT_DURATION_S: f64 = 4.0;

/// The planned time of a move of `deg`: the one with the paper's slew's peak reference
/// acceleration, 0.35 s * sqrt(deg / 180).
pub fn planned_time_s(deg: f64) -> f64 {
    0.35 * (deg.abs() / 180.0).sqrt()
}

/// The multipliers and payload of one case.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Perturbation {
    /// EI multiplier.
    pub ei: f64,
    /// Density (rho) multiplier.
    pub rho: f64,
    /// Jm multiplier.
    pub jm: f64,
    /// Viscous and Coulomb friction multiplier.
    pub friction: f64,
    /// Damping ratio multiplier (unused when `damping_ratio` is drawn).
    pub damping: f64,
    /// The damping ratio, when drawn from [`SweepSpec::damping_ratio`].
    pub damping_ratio: Option<f64>,
    /// Payload, kg.
    pub payload_kg: f64,
    /// Coulomb friction, N m, when drawn (`coulomb_max_nm` > 0).
    pub coulomb_nm: Option<f64>,
    /// The move's amplitude, deg (`None`: the paper's slew).
    pub move_deg: Option<f64>,
    /// Plan it at the planner's shortest time.
    pub shortest: bool,
    /// Plan it exact on the law's reference beam ([`SweepSpec::exact`]).
    pub exact: bool,
    /// Its time, s, if not the planned one ([`SweepSpec::move_time_s`]).
    pub move_time_s: Option<f64>,
}

impl Perturbation {
    /// Draws case `index` of `spec`.
    pub fn draw(spec: &SweepSpec, index: usize) -> Self {
        let mut rng = StdRng::seed_from_u64(
            spec.seed
                .wrapping_mul(0x9E37_79B9_7F4A_7C15)
                .wrapping_add(index as u64),
        );
        let mut f = || 1.0 + spec.spread * (2.0 * rng.gen::<f64>() - 1.0);
        let (ei, rho, jm, friction, damping) = (f(), f(), f(), f(), f());
        let payload_kg = spec.payload_max_kg * rng.gen::<f64>();
        // Drawn after the others, so a spec without them draws the same cases as before.
        let coulomb_nm =
            (spec.coulomb_max_nm > 0.0).then(|| spec.coulomb_max_nm * rng.gen::<f64>());
        // Last of all, for the same reason.
        let damping_ratio = spec
            .damping_ratio
            .map(|(low, high)| low * (high / low).powf(rng.gen::<f64>()));
        Self {
            ei,
            rho,
            jm,
            friction,
            damping,
            damping_ratio,
            payload_kg,
            coulomb_nm,
            move_deg: (!spec.moves_deg.is_empty())
                .then(|| spec.moves_deg[index % spec.moves_deg.len()]),
            shortest: spec.shortest && !spec.moves_deg.is_empty(),
            exact: spec.exact,
            move_time_s: spec.move_time_s,
        }
    }

    /// The case's move with `shaper` (stretched by it: a short move cannot absorb its length).
    pub fn motion(&self, shaper: Shaper) -> Motion {
        match self.move_deg {
            None => Motion {
                shaper,
                ..Motion::default()
            },
            Some(deg) => {
                let half = (deg / 2.0).to_radians() as f32;
                Motion {
                    from_rad: -half,
                    to_rad: half,
                    time_s: self.move_time_s.unwrap_or_else(|| planned_time_s(deg)) as f32,
                    shaper,
                    timing: Timing::Stretch,
                    shortest: self.shortest,
                    exact: self.exact,
                    ..Motion::default()
                }
            }
        }
    }

    /// The damping ratio drawn over `nominal`'s: the multiplier, or the drawn ratio's share
    /// of the nominal one when it came from [`SweepSpec::damping_ratio`].
    pub fn damping_scale(&self, nominal: &BeamParams) -> f64 {
        self.damping_ratio
            .map_or(self.damping, |r| r / nominal.damping_ratio)
    }

    /// The perturbed plant parameters from `nominal`.
    pub fn apply(&self, nominal: &BeamParams) -> BeamParams {
        BeamParams {
            ei_nm2: nominal.ei_nm2 * self.ei,
            density_kg_m3: nominal.density_kg_m3 * self.rho,
            jm_kgm2: nominal.jm_kgm2 * self.jm,
            viscous_nms: nominal.viscous_nms * self.friction,
            coulomb_nm: self
                .coulomb_nm
                .unwrap_or(nominal.coulomb_nm * self.friction),
            damping_ratio: self
                .damping_ratio
                .unwrap_or(nominal.damping_ratio * self.damping)
                .min(0.99),
            tip_mass_kg: self.payload_kg,
            ..*nominal
        }
    }
}

/// One case's outcome.
#[derive(Clone, Debug, PartialEq)]
pub struct Case {
    /// What was drawn.
    pub perturbation: Perturbation,
    /// The designed controller's metrics.
    pub controller: Metrics,
    /// The PD baseline's metrics.
    pub baseline: Metrics,
    /// The peer's metrics (feedforward + PD with its shaper), when one is given.
    pub peer: Option<Metrics>,
}

/// A law with its shaper, as scheduled for a payload.
pub type Tuned = (Law, Shaper);

/// One case's beams: the plant as drawn, the nominal model at the drawn payload, which the
/// drive is built on, and the beam its known parts are built on
/// ([`SweepSpec::known_params`]).
struct CaseBeams<const N: usize> {
    index: usize,
    perturbation: Perturbation,
    plant: ModalModel<N>,
    nominal: ModalModel<N>,
    known: ModalModel<N>,
    /// The factor on the shapers' frequencies: 1, or the drawn beam's first hub-free
    /// frequency against the nominal beam's at the payload, if the drive knows the reference
    /// ([`SweepSpec::drive_knows`]).
    shaper_scale: f32,
}

impl<const N: usize> CaseBeams<N> {
    fn draw(nominal: &BeamParams, spec: &SweepSpec, index: usize) -> Result<Self, SimError> {
        let p = Perturbation::draw(spec, index);
        let build = |params: BeamParams| -> Result<ModalModel<N>, SimError> {
            Ok(ModalModel::try_build(&Beam::try_build(params)?)?)
        };
        let plant = build(p.apply(nominal))?;
        let at_payload = build(BeamParams {
            tip_mass_kg: p.payload_kg,
            ..*nominal
        })?;
        let known = if spec.known_params == KnownParams::ALL || spec.drive_knows == Known::NONE {
            plant
        } else {
            build(spec.known_params.apply(&p, nominal))?
        };
        let shaper_scale = if spec.drive_knows.reference {
            (known.pinned_hz[0] / at_payload.pinned_hz[0]) as f32
        } else {
            1.0
        };
        Ok(Self {
            index,
            perturbation: p,
            plant,
            nominal: at_payload,
            known,
            shaper_scale,
        })
    }

    /// `law` with its shaper through the case's move, sensors seeded per case.
    fn run(&self, spec: &SweepSpec, (law, shaper): Tuned) -> Result<SimResult, SimError> {
        let shaper = Shaper {
            freq_hz: shaper.freq_hz * self.shaper_scale,
            ..shaper
        };
        let opts = SimOptions {
            sensors: SensorConfig {
                seed: spec.seed ^ self.index as u64,
                strain_noise_std: spec.strain_noise_std,
                ..SensorConfig::reading(spec.instruments)
            },
            motion: self.perturbation.motion(shaper),
            duration_s: spec.duration_s,
            true_state: spec.true_state,
            ..Default::default()
        };
        simulate_knowing(
            &self.plant,
            &self.known,
            &self.nominal,
            spec.drive_knows,
            law,
            &opts,
        )
    }
}

/// Runs the sweep. `law_for_payload` gives the controller's gains at a payload (the gain
/// table's schedule); `baseline` is the comparison law.
pub fn sweep<const N: usize>(
    nominal: &BeamParams,
    spec: &SweepSpec,
    law_for_payload: &(dyn Fn(f64) -> Tuned + Sync),
    baseline: Law,
    peer: Option<&(dyn Fn(f64) -> Tuned + Sync)>,
) -> Result<Vec<Case>, SimError> {
    (0..spec.cases)
        .into_par_iter()
        .map(|i| {
            let case = CaseBeams::<N>::draw(nominal, spec, i)?;
            let p = case.perturbation;
            let run = |tuned| {
                case.run(spec, tuned)
                    .map(|r| metrics_with(&r, &spec.settle))
            };
            Ok(Case {
                perturbation: p,
                controller: run(law_for_payload(p.payload_kg))?,
                baseline: run((baseline, Shaper::NONE))?,
                peer: peer.map(|f| run(f(p.payload_kg))).transpose()?,
            })
        })
        .collect()
}

/// Case `index` of the sweep `spec` alone, the controller only: what was drawn and the whole
/// run, as [`sweep`] runs it (the same beams, move and sensor noise), to see why a case is
/// slow.
pub fn trace_case<const N: usize>(
    nominal: &BeamParams,
    spec: &SweepSpec,
    law_for_payload: &(dyn Fn(f64) -> Tuned + Sync),
    index: usize,
) -> Result<(Perturbation, SimResult), SimError> {
    let case = CaseBeams::<N>::draw(nominal, spec, index)?;
    let p = case.perturbation;
    Ok((p, case.run(spec, law_for_payload(p.payload_kg))?))
}

/// p50, p95 and max of the values (nearest-rank percentiles), NaN left out; `None` if there
/// are none. Infinity (a run that never settled) ranks last, so a p95 that falls on one is
/// infinite.
pub fn percentiles(values: impl Iterator<Item = Option<f64>>) -> Option<(f64, f64, f64)> {
    let mut v: Vec<f64> = values.flatten().filter(|x| !x.is_nan()).collect();
    if v.is_empty() {
        return None;
    }
    v.sort_by(f64::total_cmp);
    let rank = |p: f64| v[((p * v.len() as f64).ceil() as usize).clamp(1, v.len()) - 1];
    Some((rank(0.5), rank(0.95), v[v.len() - 1]))
}

/// A metric of a run, by its name in the reports.
pub type Pick = fn(&Metrics) -> Option<f64>;

/// A metric's (p50, p95, max) over the cases.
pub type Spread = (f64, f64, f64);

/// The settle time of a run that stayed in range: infinite when it never settled, so that the
/// percentiles count it; `None` after a breakdown.
pub fn settle_or_never(m: &Metrics) -> Option<f64> {
    if m.breakdown_at_s.is_some() {
        None
    } else {
        Some(m.settle_s.unwrap_or(f64::INFINITY))
    }
}

/// The metrics a sweep reports, with their names: the settle time from the move command
/// first; the windows after the move's end T; then the paper's absolute windows.
pub const SUMMARY: [(&str, Pick); 10] = [
    ("settle_s", settle_or_never),
    ("peak_torque_nm", |m| m.peak_torque_nm),
    ("peak_root_strain_ue", |m| m.peak_root_strain_ue),
    ("move_end_s", |m| m.move_end_s),
    ("rms_root_strain_ue_end_plus_0_05_0_25", |m| {
        m.rms_root_strain_ue_end_plus_0_05_0_25
    }),
    ("err_deg_end_plus_0_25", |m| m.err_deg_end_plus_0_25),
    ("err_deg_t2_0", |m| m.err_deg_t2_0),
    ("max_root_strain_ue_after_move", |m| {
        m.max_root_strain_ue_after_move
    }),
    ("rms_root_strain_ue_0_4_0_6", |m| {
        m.rms_root_strain_ue_0_4_0_6
    }),
    ("err_deg_t0_6", |m| m.err_deg_t0_6),
];

/// One law's outcome over the cases: how many broke the model, and each reported metric's
/// (p50, p95, max) over the runs that stayed in range.
#[derive(Clone, Debug, PartialEq)]
pub struct LawSummary {
    /// Cases where the model broke down.
    pub breakdowns: usize,
    /// Cases that stayed in range but had not settled when the run ended.
    pub unsettled: usize,
    /// Cases where the drive latched a fault (a sensor, the strain trip), breakdowns
    /// included: a gauge taken for failed on a beam that is only off the model is a false
    /// alarm.
    pub faulted: usize,
    /// [`SUMMARY`]'s metrics, by name.
    pub metrics: Vec<(&'static str, Option<Spread>)>,
}

impl LawSummary {
    /// The summary of the runs `pick` takes from each case (`None`: that case has none).
    pub fn of(cases: &[Case], pick: impl Fn(&Case) -> Option<&Metrics>) -> Self {
        Self {
            breakdowns: cases
                .iter()
                .filter(|c| pick(c).is_some_and(|m| m.breakdown_at_s.is_some()))
                .count(),
            unsettled: cases
                .iter()
                .filter(|c| pick(c).and_then(settle_or_never) == Some(f64::INFINITY))
                .count(),
            faulted: cases
                .iter()
                .filter(|c| pick(c).is_some_and(|m| m.faulted))
                .count(),
            metrics: SUMMARY
                .iter()
                .map(|(name, metric)| {
                    (
                        *name,
                        percentiles(cases.iter().map(|c| pick(c).and_then(metric))),
                    )
                })
                .collect(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn percentiles_by_nearest_rank() {
        let v = (1..=100).map(|x| Some(x as f64));
        assert_eq!(percentiles(v), Some((50.0, 95.0, 100.0)));
        assert_eq!(
            percentiles([None, Some(3.0)].into_iter()),
            Some((3.0, 3.0, 3.0))
        );
        assert_eq!(percentiles([None, Some(f64::NAN)].into_iter()), None);
        // A run that never settled ranks last: one in twenty puts p95 on a finite value, two
        // put it on "never".
        let with = |never: usize| {
            (0..20).map(move |i| Some(if i < never { f64::INFINITY } else { i as f64 }))
        };
        assert_eq!(percentiles(with(1)).unwrap().1, 19.0);
        assert_eq!(percentiles(with(2)).unwrap().1, f64::INFINITY);
    }

    /// Ten cases within 20 %, up to 50 g, the paper's slew, seed 3.
    fn spec() -> SweepSpec {
        SweepSpec {
            cases: 10,
            spread: 0.2,
            damping_ratio: None,
            payload_max_kg: 0.05,
            seed: 3,
            coulomb_max_nm: 0.0,
            moves_deg: vec![],
            shortest: false,
            exact: false,
            move_time_s: None,
            duration_s: DEFAULT_DURATION_S,
            settle: SettleSpec::default(),
            instruments: Instruments::DEFAULT,
            strain_noise_std: beam_sim::sensors::STRAIN_NOISE_STD,
            true_state: false,
            drive_knows: Known::NONE,
            known_params: KnownParams::ALL,
        }
    }

    /// A drive that knows only some of the drawn beam's parameters is built on a beam with
    /// those and the nominal rest: knowing the stiffness against the mass gives the drawn
    /// beam's clamped frequencies (a cantilever's go as `sqrt(EI / rho)`) on the nominal
    /// mass; knowing only the damping, the nominal frequencies.
    #[test]
    fn a_drive_that_knows_some_parameters_is_built_on_those_alone() {
        let nominal = BeamParams::aluminium();
        let with = |known_params| SweepSpec {
            cases: 6,
            seed: 11,
            payload_max_kg: 0.0,
            drive_knows: Known {
                observer: true,
                ..Known::NONE
            },
            known_params,
            ..spec()
        };
        let only = |f: fn(&mut KnownParams)| {
            let mut k = KnownParams {
                stiffness: false,
                ei: false,
                density: false,
                hub: false,
                damping: false,
                friction: false,
            };
            f(&mut k);
            k
        };
        for i in 0..6 {
            let all = CaseBeams::<3>::draw(&nominal, &with(KnownParams::ALL), i).unwrap();
            assert_eq!(all.known, all.plant);
            let stiff =
                CaseBeams::<3>::draw(&nominal, &with(only(|k| k.stiffness = true)), i).unwrap();
            let p = stiff.perturbation;
            let ratio = (p.ei / p.rho).sqrt();
            for m in 0..3 {
                let (k, n) = (stiff.known.clamped_hz[m], stiff.nominal.clamped_hz[m]);
                assert!(
                    (k / n / ratio - 1.0).abs() < 1e-9,
                    "case {i} mode {m}: {k} {n}"
                );
                let drawn = stiff.plant.clamped_hz[m];
                assert!(
                    (k / drawn - 1.0).abs() < 1e-9,
                    "case {i} mode {m}: {k} {drawn}"
                );
            }
            assert_eq!(stiff.known.mtt, stiff.nominal.mtt);
            let damp =
                CaseBeams::<3>::draw(&nominal, &with(only(|k| k.damping = true)), i).unwrap();
            assert_eq!(damp.known.clamped_hz, damp.nominal.clamped_hz);
            assert_eq!(
                damp.known.beam.params().damping_ratio,
                damp.plant.beam.params().damping_ratio
            );
            assert_ne!(damp.known.cq, damp.nominal.cq);
        }
    }

    #[test]
    fn a_drive_that_knows_the_reference_moves_its_shapers_to_the_drawn_beam() {
        let spec = SweepSpec {
            cases: 4,
            seed: 5,
            drive_knows: Known::ALL,
            ..spec()
        };
        let nominal = BeamParams::aluminium();
        let unknown = SweepSpec {
            drive_knows: Known {
                reference: false,
                ..Known::ALL
            },
            ..spec.clone()
        };
        for i in 0..spec.cases {
            let knows = CaseBeams::<2>::draw(&nominal, &spec, i).unwrap();
            let not = CaseBeams::<2>::draw(&nominal, &unknown, i).unwrap();
            // The same beam and the same nominal model at its payload are drawn.
            assert_eq!((knows.plant, knows.nominal), (not.plant, not.nominal));
            assert_ne!(not.nominal, not.plant);
            assert_eq!(
                not.nominal.beam.params().tip_mass_kg,
                knows.perturbation.payload_kg
            );
            assert_eq!(not.shaper_scale, 1.0);
            let f = |m: &ModalModel<2>| m.pinned_hz[0];
            let scale = (f(&knows.plant) / f(&knows.nominal)) as f32;
            assert_eq!(knows.shaper_scale, scale);
            // A stiffer or lighter beam rings faster: the scale follows sqrt(EI / density)
            // within the payload's and Jm's share.
            let p = knows.perturbation;
            let ideal = (p.ei / p.rho).sqrt() as f32;
            assert!((scale / ideal - 1.0).abs() < 0.1, "{scale} against {ideal}");
        }
    }

    #[test]
    fn draws_are_reproducible_and_within_the_spread() {
        let spec = spec();
        let with_more = SweepSpec {
            coulomb_max_nm: 0.05,
            moves_deg: vec![15.0, 180.0],
            ..spec.clone()
        };
        for i in 0..200 {
            let p = Perturbation::draw(&spec, i);
            assert_eq!(p, Perturbation::draw(&spec, i));
            for m in [p.ei, p.rho, p.jm, p.friction, p.damping] {
                assert!((0.8..=1.2).contains(&m));
            }
            assert!((0.0..=0.05).contains(&p.payload_kg));
            assert_eq!((p.coulomb_nm, p.move_deg), (None, None));
            // Friction and moves are drawn after the rest: the other draws are unchanged.
            let q = Perturbation::draw(&with_more, i);
            assert_eq!((q.ei, q.payload_kg), (p.ei, p.payload_kg));
            assert!((0.0..=0.05).contains(&q.coulomb_nm.unwrap()));
            assert_eq!(q.move_deg, Some([15.0, 180.0][i % 2]));
        }
        // A damping ratio from a range: within it, log-uniform (half the beams below the
        // geometric middle, 1 % for 0.5-2 %, a quarter below 0.71 %), the rest as drawn
        // without it.
        let ranged = SweepSpec {
            damping_ratio: Some((0.005, 0.02)),
            ..spec.clone()
        };
        let nominal = BeamParams::aluminium();
        let ratios: Vec<f64> = (0..4000)
            .map(|i| {
                let (p, q) = (Perturbation::draw(&spec, i), Perturbation::draw(&ranged, i));
                assert_eq!(
                    (q.ei, q.damping, q.payload_kg),
                    (p.ei, p.damping, p.payload_kg)
                );
                assert_eq!(p.damping_ratio, None);
                let r = q.apply(&nominal).damping_ratio;
                assert_eq!(Some(r), q.damping_ratio);
                assert!((0.005..=0.02).contains(&r), "{r}");
                r
            })
            .collect();
        let below = |x: f64| ratios.iter().filter(|&&r| r < x).count() as f64 / 4000.0;
        // Binomial, n = 4000: one standard deviation is under 0.008.
        assert!((below(0.01) - 0.5).abs() < 0.03, "{}", below(0.01));
        assert!((below(0.005 * 2f64.sqrt()) - 0.25).abs() < 0.03);
        // The planned time keeps the paper's peak acceleration: 180 deg in 0.35 s.
        assert!((planned_time_s(180.0) - 0.35).abs() < 1e-12);
        assert!((planned_time_s(45.0) - 0.175).abs() < 1e-12);
    }
}
