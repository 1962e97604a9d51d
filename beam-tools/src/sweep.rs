//! Monte Carlo robustness: the controller, designed on the nominal model, against plants whose
//! parameters are off by up to +-spread and which carry a random payload (known to the drive,
//! which schedules its gains on it). Every case also runs the PD baseline, so the two are
//! compared on the same beams. Cases run in parallel; each has its own seeded generator, so
//! the result does not depend on the thread count.

use host_tests::metrics::{metrics, Metrics};
use host_tests::sensors::SensorConfig;
use host_tests::sim::{simulate_mismatched, SimError, SimOptions};
use model_core::{Beam, BeamParams, Law, ModalModel};
use rand::{rngs::StdRng, Rng, SeedableRng};
use rayon::prelude::*;

/// How the cases are drawn.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SweepSpec {
    /// Number of cases.
    pub cases: usize,
    /// Relative parameter error bound (0.2 = +-20 %).
    pub spread: f64,
    /// Largest payload, kg (drawn uniformly from 0).
    pub payload_max_kg: f64,
    /// Seed.
    pub seed: u64,
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
    /// Damping ratio multiplier.
    pub damping: f64,
    /// Payload, kg.
    pub payload_kg: f64,
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
        Self {
            ei,
            rho,
            jm,
            friction,
            damping,
            payload_kg: spec.payload_max_kg * rng.gen::<f64>(),
        }
    }

    /// The perturbed plant parameters from `nominal`.
    pub fn apply(&self, nominal: &BeamParams) -> BeamParams {
        BeamParams {
            ei_nm2: nominal.ei_nm2 * self.ei,
            density_kg_m3: nominal.density_kg_m3 * self.rho,
            jm_kgm2: nominal.jm_kgm2 * self.jm,
            viscous_nms: nominal.viscous_nms * self.friction,
            coulomb_nm: nominal.coulomb_nm * self.friction,
            damping_ratio: (nominal.damping_ratio * self.damping).min(0.99),
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
}

/// Runs the sweep. `law_for_payload` gives the controller's gains at a payload (the gain
/// table's schedule); `baseline` is the comparison law.
pub fn sweep<const N: usize>(
    nominal: &BeamParams,
    spec: &SweepSpec,
    law_for_payload: &(dyn Fn(f64) -> Law + Sync),
    baseline: Law,
) -> Result<Vec<Case>, SimError> {
    (0..spec.cases)
        .into_par_iter()
        .map(|i| {
            let p = Perturbation::draw(spec, i);
            let build = |params: BeamParams| -> Result<ModalModel<N>, SimError> {
                Ok(ModalModel::try_build(&Beam::try_build(params)?)?)
            };
            let plant = build(p.apply(nominal))?;
            let drive = build(BeamParams {
                tip_mass_kg: p.payload_kg,
                ..*nominal
            })?;
            let opts = SimOptions {
                sensors: SensorConfig {
                    seed: spec.seed ^ i as u64,
                    ..Default::default()
                },
                ..Default::default()
            };
            let run = |law| simulate_mismatched(&plant, &drive, law, &opts).map(|r| metrics(&r));
            Ok(Case {
                perturbation: p,
                controller: run(law_for_payload(p.payload_kg))?,
                baseline: run(baseline)?,
            })
        })
        .collect()
}

/// p50, p95 and max of the finite values (nearest-rank percentiles); `None` if there are none.
pub fn percentiles(values: impl Iterator<Item = Option<f64>>) -> Option<(f64, f64, f64)> {
    let mut v: Vec<f64> = values.flatten().filter(|x| x.is_finite()).collect();
    if v.is_empty() {
        return None;
    }
    v.sort_by(f64::total_cmp);
    let rank = |p: f64| v[((p * v.len() as f64).ceil() as usize).clamp(1, v.len()) - 1];
    Some((rank(0.5), rank(0.95), v[v.len() - 1]))
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
    }

    #[test]
    fn draws_are_reproducible_and_within_the_spread() {
        let spec = SweepSpec {
            cases: 10,
            spread: 0.2,
            payload_max_kg: 0.05,
            seed: 3,
        };
        for i in 0..200 {
            let p = Perturbation::draw(&spec, i);
            assert_eq!(p, Perturbation::draw(&spec, i));
            for m in [p.ei, p.rho, p.jm, p.friction, p.damping] {
                assert!((0.8..=1.2).contains(&m));
            }
            assert!((0.0..=0.05).contains(&p.payload_kg));
        }
    }
}
