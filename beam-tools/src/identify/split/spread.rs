//! How sure the split calibration is: the bootstrap spread of the torque balance, the shifts
//! of the windows, the standard errors and the trade-offs between parameters.

use super::*;

/// How well the balance's results are known: by a moving-block bootstrap (noise), and by
/// how far they move with the hub smoothed differently and the angle re-quantised (the
/// model's error, the encoder's).
pub(super) struct BalanceSpread {
    /// The bootstrap's results, [`Balance::derived`] each.
    pub(super) boot: Vec<[f64; 6]>,
    pub(super) noise: Vec<f64>,
    pub(super) shift: [f64; 6],
    pub(super) encoder: [f64; 6],
    /// The three in quadrature.
    pub(super) sd: Vec<f64>,
    /// The results this reference reports (indices into [`BALANCE_NAMES`]).
    pub(super) used: Vec<usize>,
    pub(super) reference: Reference,
    /// The beam was held ([`Balance::beam_held`]): its density and the torque's scale are
    /// not results.
    pub(super) beam_held: bool,
}

pub(super) fn balance_spread<const N: usize>(
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
    let held = balance.beam_held;
    let boot = bootstrap(&balance.rows, exps, offset_fitted, held, block_s)
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
        let da = balance.derived(&fit_balance_as(&alt_rows, offset_fitted, held)?, reference);
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
        let da = balance.derived(&fit_balance_as(&alt_rows, offset_fitted, held)?, reference);
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
            1 => matches!(reference, Reference::Torque) && !held,
            4 => reference.measures_scale() && !held,
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
        beam_held: held,
    })
}

/// Each result's noise, and its shifts with the hub's smoothing and the encoder: the
/// balance's, then step 1's in the parameters' units (EI's from EI/rho alone unless step 1
/// fits the density too).
pub(super) fn window_shifts(
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
pub(super) fn uncertainties(
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
        Reference::Torque if spread.beam_held => {}
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
    if reference.measures_scale() && !spread.beam_held {
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
pub(super) fn tradeoffs(spread: &BalanceSpread, beam: &BeamFit) -> Vec<Tradeoff> {
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
pub(super) struct CheckFigures {
    pub(super) balance_rms_err_nm: f64,
    pub(super) balance_rms_torque_nm: f64,
    pub(super) replay_rms_theta_err_rad: f64,
    pub(super) move_span_rad: f64,
}

pub(super) fn check_figures<const N: usize>(
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

/// The first lag, in rows, at which the autocorrelation of `r` falls below 1/e (at most half
/// its length).
pub(super) fn decorrelation_lag(r: &[f64]) -> usize {
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
pub(super) fn correlation(samples: &[[f64; 6]], a: usize, b: usize) -> f64 {
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
