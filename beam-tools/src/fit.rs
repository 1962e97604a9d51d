//! The search both gain design and identification run: a quantity searched within bounds
//! (on a log scale for a positive one), mapped to and from the unit cube ([`Param`]), a
//! Latin hypercube over the cube, and a multi-start local search from it ([`minimise`]).

use rand::{rngs::StdRng, Rng, SeedableRng};
use rayon::prelude::*;

/// One searched quantity (a gain, a beam parameter): its name, bounds, and whether it is
/// searched on a log scale.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Param {
    /// Its name (a gain's, `kp`, `w`, ..., or a parameter's, `ei_nm2`, ...).
    pub name: &'static str,
    /// Lower bound.
    pub lo: f64,
    /// Upper bound.
    pub hi: f64,
    /// Search log(x) (positive gains) rather than x.
    pub log: bool,
}

impl Param {
    /// The unit-cube coordinate of gain `x` (clamped to the bounds).
    pub fn unit_of(&self, x: f64) -> f64 {
        let u = if self.log {
            (x.max(f64::MIN_POSITIVE).ln() - self.lo.ln()) / (self.hi.ln() - self.lo.ln())
        } else {
            (x - self.lo) / (self.hi - self.lo)
        };
        if u.is_finite() {
            u.clamp(0.0, 1.0)
        } else {
            0.5
        }
    }

    /// The gain at unit-cube coordinate `u`.
    pub fn gain_at(&self, u: f64) -> f64 {
        let u = u.clamp(0.0, 1.0);
        if self.log {
            (self.lo.ln() + u * (self.hi.ln() - self.lo.ln())).exp()
        } else {
            self.lo + u * (self.hi - self.lo)
        }
    }
}

/// `samples` points of a Latin hypercube in the unit cube of `dims` dimensions: one point in
/// each of `samples` equal strata of every coordinate, strata paired at random (seeded).
pub fn latin_hypercube(samples: usize, dims: usize, seed: u64) -> Vec<Vec<f64>> {
    let mut rng = StdRng::seed_from_u64(seed);
    let columns: Vec<Vec<f64>> = (0..dims)
        .map(|_| {
            let mut strata: Vec<usize> = (0..samples).collect();
            for i in (1..strata.len()).rev() {
                strata.swap(i, rng.gen_range(0..=i));
            }
            strata
                .into_iter()
                .map(|s| (s as f64 + rng.gen::<f64>()) / samples as f64)
                .collect()
        })
        .collect();
    (0..samples)
        .map(|i| columns.iter().map(|c| c[i]).collect())
        .collect()
}

/// Latin-hypercube samples before [`minimise`]'s local searches.
pub const SAMPLES: usize = 96;

/// [`minimise`]'s local searches besides the one from its start.
pub const LOCAL_STARTS: usize = 5;

/// Minimises `f` over the unit cube in `dims` dimensions: a Latin hypercube of
/// [`SAMPLES`] points (from `seed`), evaluated in parallel, then COBYLA with `evals`
/// evaluations from `start` and the [`LOCAL_STARTS`] best samples (the costs here have
/// several basins), each until its step is below `xtol` relative to the point; returns the
/// best point found (`start` if none is better).
pub fn minimise(
    dims: usize,
    start: Vec<f64>,
    evals: usize,
    seed: u64,
    xtol: f64,
    f: &(dyn Fn(&[f64]) -> f64 + Sync),
) -> Vec<f64> {
    let mut scored: Vec<(f64, Vec<f64>)> = latin_hypercube(SAMPLES, dims, seed)
        .into_par_iter()
        .map(|u| (f(&u), u))
        .collect();
    scored.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut starts: Vec<Vec<f64>> = vec![start.clone()];
    starts.extend(scored.into_iter().take(LOCAL_STARTS).map(|(_, u)| u));
    let bounds = vec![(0.0, 1.0); dims];
    starts
        .par_iter()
        .map(|u0| {
            let cons: [&dyn cobyla::Func<()>; 0] = [];
            let u = match cobyla::minimize(
                |u: &[f64], _: &mut ()| f(u),
                u0,
                &bounds,
                &cons,
                (),
                evals,
                cobyla::RhoBeg::All(0.1),
                Some(cobyla::StopTols {
                    xtol_rel: xtol,
                    ..Default::default()
                }),
            ) {
                Ok((_, u, _)) | Err((_, u, _)) => u,
            };
            (f(&u), u)
        })
        .collect::<Vec<_>>()
        .into_iter()
        .min_by(|a, b| a.0.total_cmp(&b.0))
        .map_or(start, |(_, u)| u)
}
