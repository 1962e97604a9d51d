//! Step 2 of the split calibration: the rigid body and friction from a torque balance on the
//! hub, integrated over short intervals while it moves, solved by linear least squares, with
//! a moving-block bootstrap of its rows.

use super::*;

/// The prescribed hub of each log, as fitted and as the results' sensitivities need it.
pub(super) struct HubViews {
    /// At the chosen smoothing width.
    pub(super) hubs: Vec<HubMotion>,
    /// At each of [`WINDOW_FACTORS`] times the width.
    pub(super) alt_hubs: Vec<Vec<HubMotion>>,
    /// Each log's angle quantised again at each of [`ENCODER_PHASES`] of its encoder's step
    /// (logs not on a grid as logged); empty when no log is.
    pub(super) requantised_logs: Vec<Vec<Log>>,
    /// The hub of each of those.
    pub(super) enc_hubs: Vec<Vec<HubMotion>>,
    /// Each log's encoder step, rad.
    pub(super) steps: Vec<Option<f64>>,
}

impl HubViews {
    pub(super) fn of(exps: &[Experiment], window: f64, given_step: Option<f64>) -> Self {
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
pub(super) struct BalanceInputs<'a> {
    pub(super) exps: &'a [Experiment],
    /// The hub's rates at the intervals' ends.
    pub(super) rates: &'a [HubMotion],
    /// The strain observers of the balance's beam.
    pub(super) observers: &'a [StrainObserver],
}

/// Step 2's result.
pub(super) struct Balance {
    /// The beam the balance ran on (step 1's, its density iterated with a trusted torque).
    pub(super) params: BeamParams,
    pub(super) rows: Vec<Row>,
    /// Jm, the density's factor (or the torque scale), viscous, Coulomb, offset, as fitted.
    pub(super) coef: [f64; 5],
    pub(super) offset_fitted: bool,
    /// The beam's torque taken as `params` gives it (its density held, the torque read
    /// true; `coef[1]` is 1): the free fit was not physical ([`hold_beam`]).
    pub(super) beam_held: bool,
}

impl Balance {
    /// `c` as the physical results: [Jm, density, viscous, Coulomb, torque scale, offset].
    pub(super) fn derived(&self, c: &[f64; 5], reference: Reference) -> [f64; 6] {
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
pub(super) fn at_density<const N: usize>(
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
pub(super) fn solve_balance<const N: usize>(
    inputs: &BalanceInputs,
    hubs: &[HubMotion],
    beam: &BeamParams,
    options: &SplitOptions,
) -> Result<Balance, CalibrateError> {
    let mut p = *beam;
    let mut rows = vec![];
    let mut offset_fitted = false;
    let mut coef = [0.0; 5];
    // The first rows, on step 1's beam: what the balance falls back on ([`hold_beam`]).
    let mut first: Option<Vec<Row>> = None;
    for _ in 0..6 {
        let both_ways;
        (rows, both_ways) =
            balance_rows::<N>(inputs.exps, hubs, inputs.rates, &p, inputs.observers)?;
        if options.fit_offset && !both_ways {
            return Err(CalibrateError::OneWay);
        }
        first.get_or_insert_with(|| rows.clone());
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
        let held = || {
            let free = Balance {
                params: *beam,
                rows: first.clone().unwrap_or_default(),
                coef,
                offset_fitted,
                beam_held: false,
            };
            hold_beam(free).ok_or(unphysical)
        };
        if !(scale_now > 0.0) || !(1.0 / 3.0..=3.0).contains(&(density / beam.density_kg_m3)) {
            return held();
        }
        match at_density::<N>(beam, inputs.exps, density) {
            Some(q) => p = q,
            None => return held(),
        }
    }
    Ok(Balance {
        params: p,
        rows,
        coef,
        offset_fitted,
        beam_held: false,
    })
}

/// `free`, a balance whose fit is not physical (a negative Jm, density or torque scale),
/// fitted again with the beam's torque as its `params` give it: the density held at theirs
/// (the material's, as the user gave it, or as known) and the torque taken to read true,
/// Jm, friction (and the offset) fitted. `None` if that is not physical either: then the
/// logs cannot tell the rigid body at all. Short or slow moves of a flexible beam on a
/// coarse encoder leave the hub's and the beam's inertia nearly the same column of the
/// balance, which the free fit splits at random; the material's density is known far
/// better than that.
pub(super) fn hold_beam(free: Balance) -> Option<Balance> {
    let coef = fit_balance_as(&free.rows, free.offset_fitted, true).ok()?;
    (coef[0] > 0.0).then_some(Balance {
        coef,
        beam_held: true,
        ..free
    })
}

/// The balance's results, named in [`Balance::derived`]'s order.
pub(super) const BALANCE_NAMES: [&str; 6] = [
    "jm_kgm2",
    "density_kg_m3",
    "viscous_nms",
    "coulomb_nm",
    "torque_scale",
    "torque_offset_nm",
];

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
pub(super) fn balance_rows<const N: usize>(
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
pub(super) fn fit_balance(rows: &[Row], offset: bool) -> Result<[f64; 5], CalibrateError> {
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

/// [`fit_balance`], or with the beam held (`held`): its column moved to the torque's side
/// with a coefficient of 1, the rest fitted.
pub(super) fn fit_balance_as(
    rows: &[Row],
    offset: bool,
    held: bool,
) -> Result<[f64; 5], CalibrateError> {
    if !held {
        return fit_balance(rows, offset);
    }
    let cols: &[usize] = if offset { &[0, 2, 3, 4] } else { &[0, 2, 3] };
    let mut n = Normal::new(cols.len());
    for r in rows {
        let x: Vec<f64> = cols.iter().map(|&i| r.x[i]).collect();
        n.add(&x, r.y - r.x[1]);
    }
    let f = n
        .solve()
        .ok_or(CalibrateError::TooLittleMotion(rows.len()))?;
    let mut coef = [0.0; 5];
    coef[1] = 1.0;
    for (&i, c) in cols.iter().zip(&f.coef) {
        coef[i] = *c;
    }
    Ok(coef)
}

/// The balance refitted on [`BOOTSTRAP`] moving-block resamples of its rows (blocks of
/// `block_s` at the first log's rate), the beam held if `held`; resamples whose fit is
/// singular are skipped.
pub(super) fn bootstrap(
    rows: &[Row],
    exps: &[Experiment],
    offset: bool,
    held: bool,
    block_s: f64,
) -> Vec<[f64; 5]> {
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
        if let Ok(c) = fit_balance_as(&sample, offset, held) {
            out.push(c);
        }
    }
    out
}
