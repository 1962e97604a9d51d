//! What a user should know about a calibration, as typed values: parameters the logs do not
//! tell apart or do not pin down, results on a bound of their search, steps or logs that
//! disagree, a model that does not explain the torque, and where the hub's smoothing or the
//! encoder limit a parameter more than the noise. Each [`Warning`] prints as one sentence;
//! `beam calibrate` prints them with its report and as its JSON's `warnings`.

use crate::identify::calibrate::{AtBound, LogFit, StepReport, Tradeoff, Uncertainty};
use crate::identify::ringing::LogRinging;
use crate::identify::split::{HeldBeam, RestOffset, SplitReport, WINDOW_FACTORS, WINDOW_WARNING};
use model_core::BeamParams;
use std::fmt;

/// The parameters' intervals and the pairs that trade against each other.
pub type Spread = (Vec<Uncertainty>, Vec<Tradeoff>);

/// What a calibration found: the parameters, and how well they fit and are known.
#[derive(Clone, Debug, PartialEq)]
pub struct Calibration {
    /// The parameters found.
    pub params: BeamParams,
    /// The paper's steps (empty for the split method).
    pub steps: Vec<StepReport>,
    /// How the model fits each log.
    pub per_log: Vec<LogFit>,
    /// The split method's report.
    pub split: Option<SplitReport>,
    /// The intervals and the parameters that trade against each other (`None`: a parameter
    /// has no effect on the logs).
    pub spread: Option<Spread>,
    /// With several logs, each log calibrated alone by the same method.
    pub each_log: Vec<LogAlone>,
    /// What reading and cutting the logs, and the fit, found.
    pub notes: Vec<Warning>,
    /// Each log's own ringing against the model's first clamped mode (empty where it was
    /// not checked).
    pub ringing: Vec<LogRinging>,
}

/// One of several logs calibrated by itself.
#[derive(Clone, Debug, PartialEq)]
pub enum LogAlone {
    /// Its parameters and their intervals.
    Fitted(Vec<Uncertainty>),
    /// Why it could not be calibrated alone.
    Failed(String),
}

/// How many combined one-sigma intervals apart two results must be to be said to disagree.
pub const DISAGREE_SIGMAS: f64 = 2.0;

/// One thing a user should know about a calibration.
#[derive(Clone, Debug, PartialEq)]
pub enum Warning {
    /// A note made where the log was read or the lag found, as worded there.
    Note(String),
    /// The mid-span gauge reads zero throughout a log: taken as not measured.
    UnmeasuredMid {
        /// The log.
        file: String,
    },
    /// The beam's signal lags the model's by `lag_s`, fitted with the beam.
    LagFitted {
        /// The log.
        file: String,
        /// The sensor (`root strain`, `tip deflection`).
        sensor: &'static str,
        /// The lag taken out, s.
        lag_s: f64,
    },
    /// A move starts less than the rest the split assumes into its log.
    ShortRest {
        /// The move.
        name: String,
        /// Where it starts in the log, s.
        start_s: f64,
        /// The rest the split takes the beam to have before a move, s.
        rest_s: f64,
    },
    /// The torque balance left a torque it could not place in either direction of motion,
    /// and fitted it as an offset.
    TorqueUnplaced {
        /// The torque left, N m.
        offset_nm: f64,
        /// The balance's residual without it, N m RMS.
        rms_without_nm: f64,
        /// With it.
        rms_with_nm: f64,
        /// The offset fitted, N m.
        fitted_nm: f64,
    },
    /// The balance left a torque the same way in both directions of motion while the
    /// torque's zero was read at rest: fitted as Coulomb friction that differs by direction.
    DirectionalFriction {
        /// The mean Coulomb friction, N m.
        coulomb_nm: f64,
        /// Half the difference, N m (positive: more turning positive).
        asym_nm: f64,
        /// Its one-sigma error, N m.
        std_err_nm: f64,
        /// The balance's residual without it, N m RMS.
        rms_without_nm: f64,
        /// With it.
        rms_with_nm: f64,
    },
    /// Two parameters the logs do not tell apart.
    Tradeoff(Tradeoff),
    /// A parameter whose interval is wider than its value.
    Unpinned(Uncertainty),
    /// A parameter has no effect on the logs: no uncertainties.
    NoEffect,
    /// A parameter on (or past) a bound of its search, in the paper's step `step`.
    AtBound {
        /// The paper's step, if any.
        step: Option<&'static str>,
        /// Where it ended.
        at: AtBound,
    },
    /// The paper's steps fitted a parameter further from the result than its interval.
    StepsDisagree {
        /// The parameter at the end.
        result: Uncertainty,
        /// Each step that disagrees: its name, its value and how many sigmas off.
        apart: Vec<(&'static str, f64, f64)>,
    },
    /// One of several logs could not be calibrated alone.
    LogAloneFailed {
        /// The log.
        log: String,
        /// Why.
        why: String,
    },
    /// Logs calibrated alone disagree on a parameter.
    LogsDisagree {
        /// The parameter.
        param: &'static str,
        /// Each pair that disagrees: the logs, their values and intervals, and the sigmas.
        pairs: Vec<LogPair>,
    },
    /// The torque balance could not split the rigid body (its free fit was not physical):
    /// the beam was held at its starting density and the torque read true.
    BeamHeld(HeldBeam),
    /// The torque read other than zero at rest before the moves: taken as its offset.
    RestOffset(RestOffset),
    /// The model's first clamped mode is not where a log rings after its move.
    RingsElsewhere {
        /// The log.
        log: String,
        /// Its check.
        check: LogRinging,
    },
    /// The sensor lag fitted with the beam moved the beam's frequency away from where the
    /// logs ring: the model was calibrated again with the logs as logged.
    LagDropped {
        /// The lag that was fitted, s.
        lag_s: f64,
        /// The model's first clamped mode with it, Hz.
        with_hz: f64,
        /// Without it (the result), Hz.
        without_hz: f64,
        /// Where the logs ring, Hz (their weighted mean).
        ring_hz: f64,
        /// Where the model with the lag rang on the same hubs, Hz.
        model_ring_hz: f64,
    },
    /// The found model, driven open loop by the logged torque, drifts from the logged angle.
    ReplayDrifts {
        /// The drift, deg RMS.
        rms_deg: f64,
        /// As a percentage of the move.
        percent_of_move: f64,
    },
    /// A parameter moves by more than its noise when the prescribed hub is smoothed over
    /// another width.
    SmoothingLimits {
        /// The parameter.
        name: &'static str,
        /// How far it moves.
        shift: f64,
        /// Its noise.
        noise: f64,
    },
    /// A parameter moves by more than its noise when the angle is quantised again at other
    /// phases of the encoder's step.
    EncoderLimits {
        /// The parameter.
        name: &'static str,
        /// How far it moves, RMS.
        shift: f64,
        /// Its noise.
        noise: f64,
    },
}

/// Two logs, each calibrated alone, apart on a parameter.
#[derive(Clone, Debug, PartialEq)]
pub struct LogPair {
    /// The first log and its value and interval.
    pub a: (String, f64, f64),
    /// The second.
    pub b: (String, f64, f64),
    /// How many combined intervals apart.
    pub sigmas: f64,
}

impl fmt::Display for Warning {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Warning::Note(text) => f.write_str(text),
            Warning::UnmeasuredMid { file } => write!(
                f,
                "{file}: the mid-span strain reads zero throughout; taken as not measured"
            ),
            Warning::LagFitted {
                file,
                sensor,
                lag_s,
            } => write!(
                f,
                "{file}: the {sensor} lags the model's (on the logged hub) by {lag_s:.3} s, fitted with the beam (a sensor amplifier's filter, or a sample clock behind the encoder's); its readings are taken {lag_s:.3} s later (give --strain-delay 0 to keep them as logged)"
            ),
            Warning::ShortRest {
                name,
                start_s,
                rest_s,
            } => write!(
                f,
                "{name}: the move starts {start_s:.3} s into the log, with less than {rest_s} s of rest before it; the split takes the beam as at rest there, and a log cut this close to the move can bias the beam's fit (start the log earlier)"
            ),
            Warning::TorqueUnplaced {
                offset_nm,
                rms_without_nm,
                rms_with_nm,
                fitted_nm,
            } => write!(
                f,
                "the torque balance left {offset_nm:.3e} N m that it could not place in either direction of motion (the balance's residual {rms_without_nm:.2e} N m RMS, {rms_with_nm:.2e} with it): the torque's zero is off, or Coulomb friction differs between the directions (by twice that); a torque offset is fitted ({fitted_nm:.3e} N m)"
            ),
            Warning::Tradeoff(t) => write!(
                f,
                "{} and {} trade against each other (correlation {:.3}); the logs do not tell them apart ({})",
                t.a, t.b, t.correlation, separates(t.a, t.b)
            ),
            Warning::Unpinned(u) => write!(
                f,
                "{}'s interval ({:.1e}) is wider than its value ({:.4e}): the logs do not pin it down (it matters little to them; if you know it, put it in --params)",
                u.name, u.std_err, u.value
            ),
            Warning::NoEffect => {
                f.write_str("a parameter has no effect on these logs; no uncertainties")
            }
            Warning::AtBound { step, at } => at_bound(f, *step, at),
            Warning::StepsDisagree { result, apart } => {
                let apart: Vec<String> = apart
                    .iter()
                    .map(|(s, v, sigmas)| format!("\"{s}\" {v:.4e} ({sigmas:.0} sigma)"))
                    .collect();
                write!(
                    f,
                    "the steps disagree on {}: {:.4e} +- {:.1e} at the end, but {}; its interval is the noise's alone and understates how well it is known",
                    result.name,
                    result.value,
                    result.std_err,
                    apart.join(", ")
                )
            }
            Warning::LogAloneFailed { log, why } => {
                write!(f, "{log} alone could not be calibrated: {why}")
            }
            Warning::LogsDisagree { param, pairs } => {
                let pairs: Vec<String> = pairs
                    .iter()
                    .map(|p| {
                        format!(
                            "{} {:.4e} +- {:.1e} against {} {:.4e} +- {:.1e} ({:.1} sigma)",
                            p.a.0, p.a.1, p.a.2, p.b.0, p.b.1, p.b.2, p.sigmas
                        )
                    })
                    .collect();
                write!(
                    f,
                    "the logs, each calibrated alone, disagree on {param}: {}; the joint result averages moves the model does not fit alike",
                    pairs.join("; ")
                )
            }
            Warning::RingsElsewhere { log, check } => {
                let (l, m) = (check.log.expect("rings"), check.model.expect("rings"));
                write!(
                    f,
                    "{log}: the model rings at {:.3} +- {:.3} Hz after the move on the logged hub, the log at {:.3} +- {:.3} Hz ({:+.1} %): the model explains the log by something else than the beam's frequency; check the sensor's lag (--strain-delay), the tip mass and the beam's drawing",
                    m.hz,
                    m.hz_sigma,
                    l.hz,
                    l.hz_sigma,
                    100.0 * check.off().unwrap_or(0.0)
                )
            }
            Warning::LagDropped {
                lag_s,
                with_hz,
                without_hz,
                ring_hz,
                model_ring_hz,
            } => write!(
                f,
                "a sensor lag of {lag_s:.3} s fitted with the beam bought its fit with the beam's frequency (first clamped mode {with_hz:.3} Hz; it rang at {model_ring_hz:.3} Hz on the logged hubs, the logs at {ring_hz:.3} Hz): calibrated again with the logs as logged, first clamped mode {without_hz:.3} Hz; give --strain-delay to keep a lag you know"
            ),
            Warning::DirectionalFriction {
                coulomb_nm,
                asym_nm,
                std_err_nm,
                rms_without_nm,
                rms_with_nm,
            } => write!(
                f,
                "the hub's Coulomb friction differs by direction: {:.3e} N m turning positive, {:.3e} N m turning negative (+- {std_err_nm:.1e}; the torque's zero is read at rest, so a torque the same both ways while the hub turns is friction; the balance's residual {rms_without_nm:.2e} -> {rms_with_nm:.2e} N m RMS); the parameter file's coulomb_asym_nm carries it",
                coulomb_nm + asym_nm,
                coulomb_nm - asym_nm
            ),
            Warning::RestOffset(o) => write!(
                f,
                "the torque reads {:.3e} +- {:.1e} N m at rest before the moves, where the hub takes none: taken as the torque's offset and subtracted (the parameter file's torque_offset_nm carries it)",
                o.offset_nm, o.std_err_nm
            ),
            Warning::BeamHeld(h) => {
                let free = h.free.map_or(String::new(), |(jm, rho, s)| {
                    format!(" (the free torque balance gave Jm {jm:.3e} kg m^2, density {rho:.4e} kg/m^3, torque scale {s:.3})")
                });
                if h.density_given {
                    write!(
                        f,
                        "the logs do not give the torque's scale with the density given{free}: the torque is read true, and Jm and friction are fitted with the given density ({:.4e} kg/m^3); log the move again with a weighed tip mass (--tip-masses) to measure the scale",
                        h.density_kg_m3
                    )
                } else {
                    write!(
                        f,
                        "the logs do not tell the hub's inertia from the beam's{free}: the beam is held at the starting density ({:.4e} kg/m^3) with the torque read true, and Jm and friction are fitted with them; give the density you know (--known-density or --material) or log the move again with a weighed tip mass (--tip-masses) to measure them",
                        h.density_kg_m3
                    )
                }
            }
            Warning::ReplayDrifts {
                rms_deg,
                percent_of_move,
            } => write!(
                f,
                "the found model, driven open loop by the logged torque, drifts {rms_deg:.1} deg RMS from the logged angle, {percent_of_move:.0} % of the move: it does not explain the torque; check the starting parameters (each log's tip mass, the gauge's position) against the rig"
            ),
            Warning::SmoothingLimits { name, shift, noise } => {
                let [lo, hi] = WINDOW_FACTORS;
                write!(
                    f,
                    "{name} moves {shift:.1e} when the prescribed hub is smoothed over {lo:.1} or {hi:.1} times the width, {:.0} times its noise: how the hub's fast motion is modelled limits it on these logs more than their noise (its interval counts the shift)",
                    shift / noise
                )
            }
            Warning::EncoderLimits { name, shift, noise } => write!(
                f,
                "{name} moves {shift:.1e} RMS when the logged angle is quantised again at other phases of its encoder's step, {:.0} times its noise: the encoder's resolution limits it on these logs more than their noise (its interval counts the shift)",
                shift / noise
            ),
        }
    }
}

/// What tells parameters `a` and `b` apart, in words.
fn separates(a: &str, b: &str) -> &'static str {
    let pair = |x: &str, y: &str| (a == x && b == y) || (a == y && b == x);
    if pair("jm_kgm2", "density_kg_m3") {
        "the same move logged again with a weighed tip mass separates them (--tip-masses), as does the density given (--known-density)"
    } else if pair("viscous_nms", "coulomb_nm") {
        "moves at other speeds separate them"
    } else {
        "other moves, or one of them known, separate them"
    }
}

/// How much a warning asks of the user, most first: 0, the result is suspect (the model
/// does not explain the logs, or the logs disagree); 1, a fit limited by the data or a
/// choice made for the user that may be wrong; 2, what was done to the logs; 3, what the
/// logs cannot tell, which the intervals already show.
impl Warning {
    /// The warning's rank, 0 first.
    pub fn rank(&self) -> u8 {
        match self {
            Warning::ReplayDrifts { .. }
            | Warning::RingsElsewhere { .. }
            | Warning::LogsDisagree { .. }
            | Warning::LogAloneFailed { .. }
            | Warning::StepsDisagree { .. }
            | Warning::AtBound { .. } => 0,
            Warning::ShortRest { .. }
            | Warning::LagDropped { .. }
            | Warning::BeamHeld(_)
            | Warning::TorqueUnplaced { .. }
            | Warning::SmoothingLimits { .. }
            | Warning::EncoderLimits { .. }
            | Warning::NoEffect => 1,
            Warning::Note(_)
            | Warning::UnmeasuredMid { .. }
            | Warning::LagFitted { .. }
            | Warning::DirectionalFriction { .. }
            | Warning::RestOffset(_) => 2,
            Warning::Tradeoff(_) | Warning::Unpinned(_) => 3,
        }
    }
}

/// The warnings a run prints as warnings; the rest are summed up in a line
/// ([`ranked`], [`more_line`]). Every one is in the JSON.
pub const SHOWN_WARNINGS: usize = 3;

/// `warnings` most serious first ([`Warning::rank`], in their order within a rank), with a
/// lag fitted alike on several logs (within a millisecond) said once for them all.
pub fn ranked(warnings: Vec<Warning>) -> Vec<Warning> {
    let mut out: Vec<Warning> = vec![];
    for w in warnings {
        if let Warning::LagFitted { file, lag_s, .. } = &w {
            let same = out.iter_mut().find_map(|o| match o {
                Warning::LagFitted {
                    file: f, lag_s: l, ..
                } if (*l - lag_s).abs() < 1e-3 => Some(f),
                _ => None,
            });
            if let Some(f) = same {
                f.push_str(&format!(", {file}"));
                continue;
            }
        }
        out.push(w);
    }
    out.sort_by_key(Warning::rank);
    out
}

/// The line that sums up the warnings past the first [`SHOWN_WARNINGS`] of `ranked`, if
/// any.
pub fn more_line(ranked: &[Warning]) -> Option<String> {
    let rest = ranked.get(SHOWN_WARNINGS..).filter(|r| !r.is_empty())?;
    let mut what: Vec<String> = rest
        .iter()
        .map(|w| match w {
            Warning::Tradeoff(t) => format!("{} with {}", t.a, t.b),
            Warning::Unpinned(u) => format!("{} not pinned down", u.name),
            Warning::AtBound { at, .. } => format!("{} at a bound", at.name),
            Warning::SmoothingLimits { name, .. } | Warning::EncoderLimits { name, .. } => {
                format!("{name} limited by the hub's data")
            }
            _ => "a note on the logs".to_string(),
        })
        .collect();
    // Each said once (a parameter limited by both the hub's smoothing and its encoder).
    let mut seen = std::collections::HashSet::new();
    what.retain(|w| seen.insert(w.clone()));
    Some(format!(
        "{} more, less pressing: {} (`--json` lists every one)",
        rest.len(),
        what.join("; ")
    ))
}

/// A parameter on a bound of its search: its value is the search's, not the logs'.
fn at_bound(f: &mut fmt::Formatter<'_>, step: Option<&str>, b: &AtBound) -> fmt::Result {
    let within = step.map_or(String::new(), |s| format!(" in the step \"{s}\""));
    if b.value < b.bound && b.bound == 0.0 {
        write!(
            f,
            "{} came out negative ({:.3e}){within} and is held at zero: the logs ask for less than none; check the torque's offset (--torque-offset) and the starting parameters",
            b.name, b.value
        )
    } else if (b.side == "upper" && b.value > b.bound * (1.0 + 1e-6))
        || (b.side == "lower" && b.value < b.bound - 1e-6 * b.bound.abs())
    {
        write!(
            f,
            "{} ended beyond the {} bound of its search{within} ({:.4e}; the search stopped at {:.4e}, the local polish went on): the starting parameters are far from what the logs say; calibrate again from the result",
            b.name, b.side, b.value, b.bound
        )
    } else {
        write!(
            f,
            "{} ended on the {} bound of its search{within} ({:.4e}): the logs push it further, so the value is the bound's; check the starting parameters",
            b.name, b.side, b.value
        )
    }
}

/// Everything a user should know about `found`, whose logs (or moves) are `names`: its own
/// notes first, then what its spread, bounds, steps, logs, replay and window shifts say.
pub fn warnings(found: &Calibration, names: &[String]) -> Vec<Warning> {
    let mut out = found.notes.clone();
    match &found.spread {
        Some((errs, trades)) => {
            out.extend(trades.iter().cloned().map(Warning::Tradeoff));
            out.extend(
                errs.iter()
                    .filter(|u| u.std_err > u.value.abs())
                    .cloned()
                    .map(Warning::Unpinned),
            );
        }
        None => out.push(Warning::NoEffect),
    }
    let bounds = found
        .steps
        .iter()
        .flat_map(|s| s.at_bound.iter().map(move |b| (Some(s.name), b)))
        .chain(
            found
                .split
                .iter()
                .flat_map(|s| s.at_bound.iter().map(|b| (None, b))),
        );
    let std_err = |name: &str| {
        found
            .spread
            .as_ref()
            .and_then(|(errs, _)| errs.iter().find(|u| u.name == name))
            .map_or(0.0, |u| u.std_err)
    };
    for (step, b) in bounds {
        // Friction held at zero from a value within its noise of zero is no news.
        let negative_noise =
            b.bound == 0.0 && b.value < 0.0 && -b.value <= DISAGREE_SIGMAS * std_err(b.name);
        if !negative_noise {
            out.push(Warning::AtBound {
                step,
                at: b.clone(),
            });
        }
    }
    if let Some((errs, _)) = &found.spread {
        out.extend(steps_disagree(&found.steps, errs));
    }
    // Logs that move different ways each fit their own direction's friction: with the
    // difference by direction found together, they are not said to disagree on it.
    out.extend(
        logs_disagree(&found.each_log, names)
            .into_iter()
            .filter(|w| {
                !matches!(
                    w,
                    Warning::LogsDisagree {
                        param: "coulomb_nm",
                        ..
                    }
                ) || found.params.coulomb_asym_nm == 0.0
            }),
    );
    if let Some(o) = found.split.as_ref().and_then(|s| s.rest_offset) {
        out.push(Warning::RestOffset(o));
    }
    if let Some(h) = found.split.as_ref().and_then(|s| s.beam_held) {
        out.push(Warning::BeamHeld(h));
    }
    for (check, name) in found.ringing.iter().zip(names) {
        if check.agrees() == Some(false) {
            out.push(Warning::RingsElsewhere {
                log: name.clone(),
                check: *check,
            });
        }
    }
    if let Some(s) = found.split.as_ref().filter(|s| s.replay_drifts()) {
        out.push(Warning::ReplayDrifts {
            rms_deg: s.replay_rms_theta_err_rad.to_degrees(),
            percent_of_move: 100.0 * s.replay_rms_theta_err_rad / s.move_span_rad,
        });
    }
    for w in found.split.iter().flat_map(|s| &s.window_shift) {
        if w.shift > WINDOW_WARNING * w.noise {
            out.push(Warning::SmoothingLimits {
                name: w.name,
                shift: w.shift,
                noise: w.noise,
            });
        }
        if w.encoder > WINDOW_WARNING * w.noise {
            out.push(Warning::EncoderLimits {
                name: w.name,
                shift: w.encoder,
                noise: w.noise,
            });
        }
    }
    out
}

/// The paper's steps that fitted a parameter to a value further from the result than
/// [`DISAGREE_SIGMAS`] times its interval: the steps see different parts of the logs, and
/// the interval (the noise's, near the result) does not count that.
pub fn steps_disagree(steps: &[StepReport], errs: &[Uncertainty]) -> Vec<Warning> {
    let mut out = vec![];
    for u in errs.iter().filter(|u| u.std_err > 0.0) {
        let apart: Vec<(&'static str, f64, f64)> = steps
            .iter()
            .filter_map(|s| {
                let (_, v) = s.fitted.iter().find(|(n, _)| *n == u.name)?;
                let sigmas = (v - u.value).abs() / u.std_err;
                (sigmas > DISAGREE_SIGMAS).then_some((s.name, *v, sigmas))
            })
            .collect();
        if !apart.is_empty() {
            out.push(Warning::StepsDisagree {
                result: u.clone(),
                apart,
            });
        }
    }
    out
}

/// Logs that, each calibrated alone, give a parameter more than [`DISAGREE_SIGMAS`] of
/// their combined intervals apart (and logs that could not be calibrated alone).
pub fn logs_disagree(each: &[LogAlone], names: &[String]) -> Vec<Warning> {
    let mut out = vec![];
    for (r, name) in each.iter().zip(names) {
        if let LogAlone::Failed(why) = r {
            out.push(Warning::LogAloneFailed {
                log: name.clone(),
                why: why.clone(),
            });
        }
    }
    let fits: Vec<(&Vec<Uncertainty>, &String)> = each
        .iter()
        .zip(names)
        .filter_map(|(r, n)| match r {
            LogAlone::Fitted(u) => Some((u, n)),
            LogAlone::Failed(_) => None,
        })
        .collect();
    let Some((first, _)) = fits.first() else {
        return out;
    };
    // Each pair is one more chance of a chance disagreement: the bar is raised so that the
    // logs' pairs together raise a false one as rarely as one pair at DISAGREE_SIGMAS does
    // (Bonferroni: 2.0 sigma for 2 logs, 2.96 for 6, i.e. 15 pairs).
    let bar = disagree_bar(fits.len() * (fits.len() - 1) / 2);
    for param in first.iter().map(|u| u.name) {
        let of = |u: &Vec<Uncertainty>| u.iter().find(|u| u.name == param).cloned();
        let mut pairs = vec![];
        for (i, (ui, ni)) in fits.iter().enumerate() {
            for (uj, nj) in &fits[i + 1..] {
                let (Some(a), Some(b)) = (of(ui), of(uj)) else {
                    continue;
                };
                let sigmas = (a.value - b.value).abs() / a.std_err.hypot(b.std_err);
                if sigmas > bar {
                    pairs.push(LogPair {
                        a: ((*ni).clone(), a.value, a.std_err),
                        b: ((*nj).clone(), b.value, b.std_err),
                        sigmas,
                    });
                }
            }
        }
        if !pairs.is_empty() {
            out.push(Warning::LogsDisagree { param, pairs });
        }
    }
    out
}

/// How many combined sigmas apart two of `pairs` results must be to be said to disagree:
/// [`DISAGREE_SIGMAS`] for one pair, raised for more so that all of them together are as
/// likely to raise a false alarm as one pair is (Gaussian intervals).
pub fn disagree_bar(pairs: usize) -> f64 {
    // Two-sided tail of the standard normal beyond z (Abramowitz and Stegun 7.1.26 for
    // erfc, within 1.5e-7).
    let tail = |z: f64| {
        let x = z / core::f64::consts::SQRT_2;
        let t = 1.0 / (1.0 + 0.3275911 * x);
        let poly = t
            * (0.254829592
                + t * (-0.284496736 + t * (1.421413741 + t * (-1.453152027 + t * 1.061405429))));
        poly * (-x * x).exp()
    };
    let want = tail(DISAGREE_SIGMAS) / pairs.max(1) as f64;
    let (mut lo, mut hi) = (DISAGREE_SIGMAS, 10.0);
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        if tail(mid) > want {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    if pairs <= 1 {
        DISAGREE_SIGMAS
    } else {
        0.5 * (lo + hi)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_bar_for_disagreeing_logs_rises_with_their_pairs() {
        assert_eq!(disagree_bar(1), DISAGREE_SIGMAS);
        // 15 pairs: a two-sided 0.0455 / 15 = 0.00303 tail is 2.965 sigma.
        assert!(
            (disagree_bar(15) - 2.965).abs() < 0.01,
            "{}",
            disagree_bar(15)
        );
        assert!(disagree_bar(3) > DISAGREE_SIGMAS && disagree_bar(3) < disagree_bar(15));
    }

    fn u(name: &'static str, value: f64, std_err: f64) -> Uncertainty {
        Uncertainty {
            name,
            value,
            std_err,
        }
    }

    fn calibration(spread: Option<Spread>) -> Calibration {
        Calibration {
            ringing: vec![],
            params: BeamParams::aluminium(),
            steps: vec![],
            per_log: vec![],
            split: None,
            spread,
            each_log: vec![],
            notes: vec![],
        }
    }

    #[test]
    fn logs_apart_by_more_than_their_combined_intervals_disagree_and_closer_ones_do_not() {
        let names = ["a.csv", "b.csv", "c.csv"].map(String::from);
        // a and b: 1.0 +- 0.1 against 1.5 +- 0.1, 3.5 sigma apart; a and c 0.7 sigma.
        let each = vec![
            LogAlone::Fitted(vec![u("ei_nm2", 1.0, 0.1)]),
            LogAlone::Fitted(vec![u("ei_nm2", 1.5, 0.1)]),
            LogAlone::Fitted(vec![u("ei_nm2", 1.1, 0.1)]),
        ];
        let w = logs_disagree(&each, &names);
        assert_eq!(w.len(), 1, "{w:?}");
        let Warning::LogsDisagree { param, pairs } = &w[0] else {
            panic!("{w:?}")
        };
        assert_eq!(*param, "ei_nm2");
        let apart: Vec<(&str, &str)> = pairs.iter().map(|p| (&*p.a.0, &*p.b.0)).collect();
        assert_eq!(apart, [("a.csv", "b.csv"), ("b.csv", "c.csv")]);
        assert!((pairs[0].sigmas - 0.5 / 0.1f64.hypot(0.1)).abs() < 1e-12);
        // A log that could not be calibrated alone is said by name.
        let failed = logs_disagree(&[LogAlone::Failed("one way".into())], &names);
        assert_eq!(
            failed[0].to_string(),
            "a.csv alone could not be calibrated: one way"
        );
    }

    #[test]
    fn a_negative_friction_within_its_noise_is_no_news_and_one_past_it_is() {
        let held = |value: f64| AtBound {
            name: "coulomb_nm",
            value,
            bound: 0.0,
            side: "lower",
        };
        let spread = Some((vec![u("coulomb_nm", 0.0, 0.01)], vec![]));
        let mut c = calibration(spread);
        c.steps = vec![StepReport {
            name: "friction",
            window: (0.0, 1.0),
            fitted: vec![],
            rms_theta_err_rad: 0.0,
            rms_strain_err_ue: 0.0,
            at_bound: vec![held(-0.015), held(-0.05)],
        }];
        let w = warnings(&c, &[]);
        let at: Vec<f64> = w
            .iter()
            .filter_map(|w| match w {
                Warning::AtBound { at, .. } => Some(at.value),
                _ => None,
            })
            .collect();
        // 1.5 sigma below zero: noise; 5 sigma: the logs ask for less than none.
        assert_eq!(at, [-0.05]);
        assert!(w
            .iter()
            .any(|w| w.to_string().contains("came out negative")));
    }

    #[test]
    fn an_interval_wider_than_its_value_and_a_tradeoff_are_said_and_no_spread_is_said() {
        let spread = Some((
            vec![u("viscous_nms", 0.001, 0.002), u("ei_nm2", 1.0, 0.01)],
            vec![Tradeoff {
                a: "jm_kgm2",
                b: "density_kg_m3",
                correlation: 0.97,
            }],
        ));
        let w = warnings(&calibration(spread), &[]);
        assert_eq!(w.len(), 2, "{w:?}");
        assert!(matches!(&w[0], Warning::Tradeoff(t) if t.a == "jm_kgm2"));
        assert!(matches!(&w[1], Warning::Unpinned(u) if u.name == "viscous_nms"));
        assert_eq!(warnings(&calibration(None), &[]), [Warning::NoEffect]);
    }

    #[test]
    fn a_step_further_from_the_result_than_twice_its_interval_disagrees() {
        let step = |name, v| StepReport {
            name,
            window: (0.0, 1.0),
            fitted: vec![("ei_nm2", v)],
            rms_theta_err_rad: 0.0,
            rms_strain_err_ue: 0.0,
            at_bound: vec![],
        };
        let steps = [step("mass", 1.05), step("all", 1.5)];
        let w = steps_disagree(&steps, &[u("ei_nm2", 1.0, 0.1)]);
        assert_eq!(w.len(), 1);
        let Warning::StepsDisagree { apart, .. } = &w[0] else {
            panic!()
        };
        assert_eq!(apart.len(), 1);
        assert_eq!(apart[0].0, "all");
        assert!((apart[0].2 - 5.0).abs() < 1e-9);
    }

    #[test]
    fn warnings_come_most_pressing_first_with_one_lag_said_once_and_the_rest_summed_up() {
        let lag = |file: &str, lag_s: f64| Warning::LagFitted {
            file: file.into(),
            sensor: "tip deflection",
            lag_s,
        };
        let trade = Warning::Tradeoff(Tradeoff {
            a: "jm_kgm2",
            b: "density_kg_m3",
            correlation: -0.97,
        });
        let drift = Warning::ReplayDrifts {
            rms_deg: 3.0,
            percent_of_move: 12.0,
        };
        let r = ranked(vec![
            trade.clone(),
            lag("a.csv", 0.015),
            lag("b.csv", 0.0152),
            lag("c.csv", 0.030),
            Warning::Unpinned(u("coulomb_nm", 0.0, 0.01)),
            drift.clone(),
        ]);
        // The drift first; the lags (two alike merged) next; what the logs cannot tell last.
        assert_eq!(r[0], drift);
        assert_eq!(r[1], lag("a.csv, b.csv", 0.015));
        assert_eq!(r[2], lag("c.csv", 0.030));
        assert_eq!(r[3], trade);
        assert_eq!(r.len(), 5);
        let more = more_line(&r).unwrap();
        assert!(
            more.starts_with("2 more") && more.contains("coulomb_nm"),
            "{more}"
        );
        assert_eq!(more_line(&r[..SHOWN_WARNINGS]), None);
    }
}
