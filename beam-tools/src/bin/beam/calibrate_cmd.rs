//! `beam calibrate`: identify the model from a logged PD slew and write it as a parameter file.

use crate::PlantArgs;
use anyhow::{bail, Context};
use beam_tools::identify::calibrate::{
    calibrate_many, find_windows, read_log_with, split_moves, BeamSensor, CalibrateError, Columns,
    Experiment, Log, LogFit, StepReport, Windows, DEFAULT_EVALS, REST_BEFORE_S,
};
use beam_tools::identify::replay::{sensor_lag, STRAIN_DELAY_FLOOR_S};
use beam_tools::identify::ringing::{
    check as ring_check, ring_mean, worst_sigmas, LogRinging, NoRinging, Ringing,
};
use beam_tools::identify::split::{calibrate_split, Reference, SplitOptions, SplitReport};
use beam_tools::identify::units::unit_mistake;
use beam_tools::identify::warnings::{
    more_line, ranked, warnings, Calibration, LogAlone, Spread, Warning, SHOWN_WARNINGS,
};
use beam_tools::io::params_file::Sensors;
use clap::Args;
use model_core::{Beam, BeamParams, ModalModel};
use serde_json::json;
use std::path::PathBuf;

#[derive(Args, Clone)]
pub struct CalibrateArgs {
    /// The logs: CSV with t_s, torque_nm, theta_rad, root_strain [, mid_strain] (or the
    /// columns of --columns, which may give a tip deflection in place of the root strain),
    /// uniformly sampled at any rate, starting at any angle. With several, one parameter
    /// set is fitted to all of them.
    #[arg(required = true, num_args = 1..)]
    logs: Vec<PathBuf>,
    /// The starting guess (preset, or --params FILE), mode count and payload.
    #[command(flatten)]
    plant: PlantArgs,
    /// Which column holds what, and its unit, when the log is not in the project's format:
    /// `t=time_ms:ms,torque=tau:nm,theta=hub:deg,strain=eps:ue,mid=mid:ue` (units: s, ms,
    /// us; nm, mnm; rad, deg; strain, ue; the others keep their default names). A rig with
    /// a tip sensor instead of a root gauge maps `tip=COL:mm` (or `:m`): the free end's
    /// deflection from the hub's line, fitted through the mode shapes at the tip.
    #[arg(long, value_name = "MAP", value_parser = Columns::parse)]
    columns: Option<Columns>,
    /// The windows, s from the log's first sample: move start, move end, end of settling
    /// [default: found in each log]; one log only.
    #[arg(long, value_name = "START,END,SETTLE_END", value_delimiter = ',')]
    windows: Option<Vec<f64>>,
    /// Use each log from this time on, s on the log's own clock (its time column).
    #[arg(long, value_name = "S", allow_negative_numbers = true)]
    from: Option<f64>,
    /// Use each log up to this time, s on the log's own clock.
    #[arg(long, value_name = "S", allow_negative_numbers = true)]
    to: Option<f64>,
    /// `split`: the beam first, on the strain with the hub prescribed, then the rigid body
    /// and friction with a torque scale; `paper`: the paper's four steps on the torque
    /// replay, kept to reproduce the paper (on real logs its steps disagree and its
    /// parameters end on their bounds; docs/calibrate-your-rig.md compares them).
    #[arg(long, value_parser = ["split", "paper"], default_value = "split")]
    method: String,
    /// With `--method split`: the beam's density is known (kg/m^3, e.g. a handbook value for
    /// its material), and the torque's scale is fitted. Without it the torque is taken to
    /// read true, and the masses, EI and friction carry its scale error: one rig's logs
    /// cannot tell the two apart (docs/calibrate-your-rig.md).
    #[arg(long, value_name = "KG_M3")]
    known_density: Option<f64>,
    /// With `--method split`: the beam's material, for its density from a handbook, as
    /// --known-density gives it: steel 7850, stainless (steel) 8000, aluminium (aluminum)
    /// 2700, brass 8500, copper 8960, titanium 4500 kg/m^3.
    #[arg(long, value_parser = MATERIALS.map(|(name, _)| name), conflicts_with = "known_density")]
    material: Option<String>,
    /// The gauge's (or tip sensor's) delay behind the hub, s: the log's strains are taken
    /// this much later (0: as logged) [default: found in each log by correlating its root
    /// strain or tip deflection with the starting parameters' on the logged hub, within
    /// 0.1 s, and applied from 3 ms].
    #[arg(long, value_name = "S", value_parser = strain_delay_value)]
    strain_delay: Option<f64>,
    /// With `--method split`: the encoder's counts per turn (after quadrature decoding), when
    /// the log's angle is printed more coarsely than the encoder counts or not on its grid
    /// [default: its step is found in each log's angle].
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(4..))]
    encoder_counts: Option<u32>,
    /// The weighed tip mass each log was recorded with, kg, one per log in the logs' order
    /// [default: every log with the starting parameters' (--tip-mass)]. With `--method
    /// split` and two different masses (the same move logged with and without a known
    /// added mass), the masses fix the level instead of the torque: the beam's frequency
    /// shift with the added mass gives its density, and the torque's scale is measured.
    #[arg(
        long,
        value_name = "KG,...",
        value_delimiter = ',',
        allow_negative_numbers = true
    )]
    tip_masses: Option<Vec<f64>>,
    /// With `--method split`: fit the root gauge's position too (it trades almost exactly
    /// against the gauge's scale; by default it is held at the starting parameters').
    #[arg(long)]
    fit_gauge_position: bool,
    /// With `--method split`: fit an offset of the logged torque (a bias, the same both
    /// ways, unlike Coulomb friction). The logs must move both ways. Without it, an offset
    /// is fitted anyway, and said, when the balance leaves a torque it cannot place in either
    /// direction (more than 4 times its error, and half the balance's residual).
    #[arg(long)]
    torque_offset: bool,
    /// COBYLA evaluations per local search.
    #[arg(long, default_value_t = DEFAULT_EVALS)]
    evals: usize,
    /// Draw the paper's calibration figures for each log: hub angle, hub rate, root strain
    /// and (where logged) mid-span strain, measured against the identified model (.png or
    /// .svg; with several logs, `NAME-2.png` and so on for the second and later).
    #[arg(long, value_name = "FILE")]
    plot: Option<PathBuf>,
    /// Write the identified parameters here (TOML; `--params FILE` of the other commands).
    #[arg(long, value_name = "FILE")]
    out: Option<PathBuf>,
    /// Print one JSON object.
    #[arg(long)]
    json: bool,
}

/// The materials `--material` names, with their handbook densities, kg/m^3.
const MATERIALS: [(&str, f64); 7] = [
    ("steel", 7850.0),
    ("stainless", 8000.0),
    ("aluminium", 2700.0),
    ("aluminum", 2700.0),
    ("brass", 8500.0),
    ("copper", 8960.0),
    ("titanium", 4500.0),
];

impl CalibrateArgs {
    /// The density given: `--known-density`, or `--material`'s.
    fn density(&self) -> Option<f64> {
        self.known_density.or_else(|| {
            let name = self.material.as_deref()?;
            MATERIALS
                .iter()
                .find(|(n, _)| *n == name)
                .map(|(_, rho)| *rho)
        })
    }
}

pub fn run(a: &CalibrateArgs) -> anyhow::Result<()> {
    check(a)?;
    let guess = *crate::beam(&a.plant)?.params();
    let mut read = experiments(a, &guess, None)?;
    let mut found = identify_joint(a, &read.exps, &guess, false)?;
    // A delay found on the starting model is off by what its frequencies are. The split
    // fits the rest of it with the beam: taken out of the logs as well, and calibrated
    // again, if it is more than a sample and a half (the split keeps none smaller). The
    // paper's method finds it again on its result.
    let beam_lag = found.split.as_ref().map(|s| s.beam_lag_s);
    if let (None, Some(lag)) = (a.strain_delay, beam_lag) {
        if read.delays.iter().any(|(_, dt)| lag.abs() > 1.5 * dt) {
            // One sensor, one lag: the logs' mean and what the beam's fit added to it (the
            // logs' own estimates scatter by a sample or so, which on a slow beam's large
            // deflection is several times the sensor's noise).
            let mean = read.delays.iter().map(|(d, _)| d).sum::<f64>() / read.delays.len() as f64;
            let total = vec![(mean + lag).max(0.0); read.delays.len()];
            read = experiments(a, &guess, Some(&total))?;
            found = identify_joint(a, &read.exps, &guess, false)?;
        }
    } else if a.strain_delay.is_none() {
        let again = experiments(a, &found.params, None)?;
        let moved = read
            .delays
            .iter()
            .zip(&again.delays)
            .any(|((d, dt), (e, _))| (d - e).abs() > 1.5 * dt);
        if moved {
            read = again;
            found = identify_joint(a, &read.exps, &guess, false)?;
        }
    }
    // The logs' own ringing holds the beam's frequency: a fitted lag that moved it away is
    // dropped, and the model calibrated again on the logs as logged.
    let mut rings = with_modes!(a.plant.modes, ring_check(&found.params, &read.exps));
    let lag = read.delays.iter().map(|(d, _)| d).sum::<f64>() / read.delays.len().max(1) as f64
        + beam_lag.unwrap_or(0.0);
    if a.strain_delay.is_none() && lag >= STRAIN_DELAY_FLOOR_S && worst_sigmas(&rings) > 0.0 {
        let as_logged = CalibrateArgs {
            strain_delay: Some(0.0),
            ..a.clone()
        };
        let again = experiments(&as_logged, &guess, None)
            .and_then(|r| Ok((identify_joint(&as_logged, &r.exps, &guess, false)?, r)));
        if let Ok((mut plain, plain_read)) = again {
            let plain_rings =
                with_modes!(a.plant.modes, ring_check(&plain.params, &plain_read.exps));
            if worst_sigmas(&plain_rings) < worst_sigmas(&rings) {
                plain.notes.push(Warning::LagDropped {
                    lag_s: lag,
                    with_hz: rings[0].model_clamped_hz,
                    without_hz: plain_rings[0].model_clamped_hz,
                    ring_hz: ring_mean(&plain_rings).unwrap_or(f64::NAN),
                    model_ring_hz: rings[0].model.map_or(f64::NAN, |r| r.hz),
                });
                (found, read, rings) = (plain, plain_read, plain_rings);
            }
        }
    }
    found.ringing = rings;
    found.each_log = each_log_alone(a, &read.exps, &guess);
    // The sensor's delay, as taken out of the logs, goes with the rig's other instruments
    // into the parameter file, for `beam replay` to take out of another log.
    if let Some(split) = found.split.as_mut() {
        let n = read.delays.len().max(1) as f64;
        split.sensors.strain_delay_s = read.delays.iter().map(|(d, _)| d).sum::<f64>() / n;
    }
    let Read {
        exps, names, notes, ..
    } = read;
    found.notes = notes.into_iter().chain(found.notes).collect();
    write_files(a, &found, &exps, &names)?;
    let (fm, gm) = with_modes!(a.plant.modes, summary(&found.params, &guess))?;
    if a.json {
        print_json(a, &found, &exps, &names, &guess, (fm, gm));
    } else {
        print_text(a, &found, &exps, &names, (fm, gm));
    }
    Ok(())
}

/// The arguments that must agree, checked before any log is read.
fn check(a: &CalibrateArgs) -> anyhow::Result<()> {
    if a.evals == 0 || a.evals > 1_000_000 {
        bail!("--evals {} must be 1..=1000000", a.evals);
    }
    if a.windows.as_ref().is_some_and(|w| w.len() != 3) {
        bail!("--windows takes three times: START,END,SETTLE_END");
    }
    if (a.density().is_some()
        || a.fit_gauge_position
        || a.torque_offset
        || a.encoder_counts.is_some())
        && a.method != "split"
    {
        bail!("--known-density, --material, --fit-gauge-position, --torque-offset and --encoder-counts apply to --method split");
    }
    if let Some(path) = &a.plot {
        beam_tools::io::plot::check_extension(path)?;
    }
    if a.windows.is_some() && a.logs.len() > 1 {
        bail!("--windows applies to one log; with several, each log's windows are found in it");
    }
    for (flag, v) in [("--from", a.from), ("--to", a.to)] {
        if v.is_some_and(|v| !v.is_finite()) {
            bail!("{flag} must be a finite time in s");
        }
    }
    if let (Some(f), Some(t)) = (a.from, a.to) {
        if f >= t {
            bail!("--from {f} must come before --to {t}");
        }
    }
    Ok(())
}

/// Each log's tip mass as given (`None`: the starting parameters'), one per log.
fn tip_masses(a: &CalibrateArgs) -> anyhow::Result<Vec<Option<f64>>> {
    Ok(match a.tip_masses.as_deref() {
        None => vec![None; a.logs.len()],
        Some(m) if m.iter().any(|m| !(m.is_finite() && *m >= 0.0)) => {
            bail!("--tip-masses: each mass must be finite and >= 0 kg")
        }
        Some(m) if m.len() == a.logs.len() => m.iter().map(|&m| Some(m)).collect(),
        Some(m) => bail!(
            "--tip-masses gives {} masses for {} logs: give one per log",
            m.len(),
            a.logs.len()
        ),
    })
}

/// The moves to calibrate on, each with its name, windows and tip mass, and what reading
/// them found: each log read, cut to --from/--to, an all-zero mid-span column dropped, its
/// strains taken back by the gauge's delay (given, or found against `model`'s strain), and
/// cut into moves if it holds several.
/// What [`experiments`] read.
struct Read {
    exps: Vec<Experiment>,
    /// Each move's name.
    names: Vec<String>,
    /// What reading found, for the warnings.
    notes: Vec<Warning>,
    /// Each log's strain delay taken out, s, and its sample period.
    delays: Vec<(f64, f64)>,
}

/// `lags`: each log's delay to take out, fitted with the beam (else found on `model`, or
/// `--strain-delay`).
fn experiments(
    a: &CalibrateArgs,
    model: &BeamParams,
    lags: Option<&[f64]>,
) -> anyhow::Result<Read> {
    let columns = a.columns.clone().unwrap_or_default();
    let (mut exps, mut names, mut notes, mut delays) = (vec![], vec![], vec![], vec![]);
    for (i, (path, tip_mass_kg)) in a.logs.iter().zip(tip_masses(a)?).enumerate() {
        let file = path.display().to_string();
        let text = std::fs::read_to_string(path).with_context(|| file.clone())?;
        let mut log = read_log_with(&text, &file, &columns)?;
        if a.from.is_some() || a.to.is_some() {
            log = log
                .between(a.from, a.to)
                .with_context(|| format!("{file} cut to --from/--to"))?;
        }
        if log.drop_unmeasured_mid() {
            notes.push(Warning::UnmeasuredMid { file: file.clone() });
        }
        // On the beam the log was made with: its own tip mass, if it has one.
        let beam = BeamParams {
            tip_mass_kg: tip_mass_kg.unwrap_or(model.tip_mass_kg),
            ..*model
        };
        // A unit or a sign read wrong, named as such before a fit fails for another reason.
        if let Some(mistake) = unit_mistake(&log, &beam) {
            bail!("{file}: {mistake}");
        }
        let (delay, note) = match lags {
            Some(lags) if lags[i] < STRAIN_DELAY_FLOOR_S => (0.0, None),
            Some(lags) => (
                lags[i],
                Some(Warning::LagFitted {
                    file: file.clone(),
                    sensor: log.sensor.name(),
                    lag_s: lags[i],
                }),
            ),
            None => {
                let (delay, note) = strain_delay_of(a, &beam, &log, &file);
                (delay, note.map(Warning::Note))
            }
        };
        notes.extend(note);
        delays.push((delay, log.t[1] - log.t[0]));
        if delay > 0.0 {
            log = log.strain_advanced(delay);
        }
        let cuts = split_moves(&log);
        if cuts.len() > 1 && a.windows.is_some() {
            bail!("{file} holds {} moves: --windows applies to a log of one move (cut it with --from/--to)", cuts.len());
        }
        let count = cuts.len();
        for (i, cut) in cuts.into_iter().enumerate() {
            let name = if count > 1 {
                format!(
                    "{file} (move {} of {count}, {:.3}..{:.3} s)",
                    i + 1,
                    cut.t[0],
                    cut.t[cut.t.len() - 1]
                )
            } else {
                file.clone()
            };
            let windows = match a.windows.as_deref() {
                Some([s, e, z]) => Windows::given(*s, *e, *z, &cut),
                Some(_) => bail!("--windows takes three times: START,END,SETTLE_END"),
                None => find_windows(&cut),
            }
            .with_context(|| name.clone())?;
            // The rest before the move as the windows see it (the cut's, or the log's start).
            if windows.start_s < REST_BEFORE_S - 1e-9 {
                notes.push(Warning::ShortRest {
                    name: name.clone(),
                    start_s: windows.start_s,
                    rest_s: REST_BEFORE_S,
                });
            }
            exps.push(Experiment {
                tip_mass_kg,
                rest_is_start: i == 0,
                ..Experiment::new(cut, windows)
            });
            names.push(name);
        }
    }
    Ok(Read {
        exps,
        names,
        notes,
        delays,
    })
}

/// The delay to take the log's beam signal back by, s, and what to say of it:
/// `--strain-delay` if given, else found on `guess` ([`sensor_lag`]).
fn strain_delay_of(
    a: &CalibrateArgs,
    guess: &BeamParams,
    log: &Log,
    file: &str,
) -> (f64, Option<String>) {
    with_modes!(a.plant.modes, sensor_lag(guess, log, file, a.strain_delay))
}

/// With several logs, each log calibrated alone as well (its parameters and intervals, or
/// why not), so that logs that disagree are seen; with one, none.
fn each_log_alone(a: &CalibrateArgs, exps: &[Experiment], guess: &BeamParams) -> Vec<LogAlone> {
    if exps.len() < 2 {
        return vec![];
    }
    exps.iter()
        .map(
            |e| match identify_joint(a, std::slice::from_ref(e), guess, true) {
                Err(e) => LogAlone::Failed(format!("{e:#}")),
                Ok(alone) => match alone.spread {
                    Some((errs, _)) => LogAlone::Fitted(errs),
                    None => LogAlone::Failed("a parameter has no effect on it".into()),
                },
            },
        )
        .collect()
}

/// One parameter set fitted to all of `exps` (`alone`: one of several, fitted by itself).
fn identify_joint(
    a: &CalibrateArgs,
    exps: &[Experiment],
    guess: &BeamParams,
    alone: bool,
) -> anyhow::Result<Calibration> {
    if a.method != "split" {
        let (params, steps, per_log) =
            with_modes!(a.plant.modes, calibrate_many(exps, guess, a.evals))?;
        let spread = with_modes!(a.plant.modes, uncertainty_n(&params, exps));
        return Ok(Calibration {
            params,
            steps,
            per_log,
            split: None,
            spread,
            each_log: vec![],
            notes: vec![],
            ringing: vec![],
        });
    }
    let mass = |e: &Experiment| e.tip_mass_kg.unwrap_or(guess.tip_mass_kg);
    let masses_differ = exps.iter().any(|e| mass(e) != mass(&exps[0]));
    let reference = match a.density() {
        Some(rho) => Reference::Density(rho),
        None if masses_differ => Reference::TipMass,
        None => Reference::Torque,
    };
    let options = SplitOptions {
        reference,
        fit_gauge_position: a.fit_gauge_position,
        fit_offset: a.torque_offset,
        fit_lag: a.strain_delay.is_none(),
        evals: a.evals,
        encoder_step_rad: a.encoder_counts.map(|n| std::f64::consts::TAU / n as f64),
    };
    let (params, sensors, split) =
        match with_modes!(a.plant.modes, calibrate_split(exps, guess, &options)) {
            // One of several logs, alone, may move one way: no offset for it (the joint
            // fit needs the logs together to move both ways, and says so).
            Err(CalibrateError::OneWay) if alone => {
                let options = SplitOptions {
                    fit_offset: false,
                    ..options
                };
                with_modes!(a.plant.modes, calibrate_split(exps, guess, &options))?
            }
            r => r?,
        };
    // A torque the balance could not place in either direction (an offset of the torque's
    // zero, or friction that differs by direction): the split fitted it; said, as a found lag
    // is.
    let notes = split
        .unplaced_offset
        .filter(|_| !options.fit_offset)
        .map(|u| Warning::TorqueUnplaced {
            offset_nm: u.offset_nm,
            rms_without_nm: u.rms_err_without_nm,
            rms_with_nm: u.rms_err_with_nm,
            fitted_nm: sensors.torque_offset_nm,
        })
        .into_iter()
        .chain(split.coulomb_asym.map(|d| Warning::DirectionalFriction {
            coulomb_nm: params.coulomb_nm,
            asym_nm: d.asym_nm,
            std_err_nm: d.std_err_nm,
            rms_without_nm: d.rms_err_without_nm,
            rms_with_nm: d.rms_err_with_nm,
        }))
        .collect();
    let per_log = with_modes!(a.plant.modes, log_fits(&params, &sensors, exps))?;
    Ok(Calibration {
        params,
        steps: vec![],
        per_log,
        spread: Some((split.uncertainty.clone(), split.tradeoffs.clone())),
        split: Some(split),
        each_log: vec![],
        notes,
        ringing: vec![],
    })
}

/// `--out` (the parameter file) and `--plot` (one figure per log).
fn write_files(
    a: &CalibrateArgs,
    found: &Calibration,
    exps: &[Experiment],
    names: &[String],
) -> anyhow::Result<()> {
    if let Some(path) = &a.out {
        let comment = format!("identified by beam calibrate from {}", names.join(", "));
        let text = beam_tools::io::params_file::render_with(
            &found.params,
            found.split.as_ref().map(|s| &s.sensors),
            &comment,
        );
        beam_tools::io::files::write_atomically(path, |w| w.write_all(text.as_bytes()))
            .with_context(|| path.display().to_string())?;
    }
    if let Some(path) = &a.plot {
        let sensors = found.split.as_ref().map(|s| s.sensors).unwrap_or_default();
        for (i, (e, name)) in exps.iter().zip(names).enumerate() {
            let target = numbered(path, i);
            let params = e.params(&found.params);
            let traces = with_modes!(a.plant.modes, traces_n(&params, &sensors, &e.log))?;
            let title = format!("identified model against {name}");
            beam_tools::io::files::plot_atomically(&target, |tmp| traces.plot(&title, tmp))?;
        }
    }
    Ok(())
}

fn print_json(
    a: &CalibrateArgs,
    found: &Calibration,
    exps: &[Experiment],
    names: &[String],
    guess: &BeamParams,
    (fm, gm): (serde_json::Value, serde_json::Value),
) {
    let steps: Vec<_> = found
        .steps
        .iter()
        .map(|s| {
            json!({"step": s.name, "window_s": [s.window.0, s.window.1],
                   "fitted": s.fitted.iter().map(|(n, v)| (n.to_string(), json!(v))).collect::<serde_json::Map<_, _>>(),
                   "rms_theta_err_rad": s.rms_theta_err_rad, "rms_strain_err_ue": s.rms_strain_err_ue})
        })
        .collect();
    let logs: Vec<_> = exps
        .iter()
        .zip(&found.per_log)
        .zip(names)
        .map(|((e, f), name)| {
            let w = &e.windows;
            let sensor = e.log.sensor;
            let mut v = json!({"log": name, "samples": e.log.t.len(), "tip_mass_kg": e.params(guess).tip_mass_kg,
                   "windows_s": [w.start_s, w.end_s, w.settle_end_s],
                   "beam_signal": sensor.name(),
                   "rms_theta_err_rad": f.rms_theta_err_rad});
            // The beam's error under its own unit's key: rms_strain_err_ue or rms_tip_err_mm.
            v[format!("rms_{}_err_{}", sensor.key(), sensor.unit())] = json!(f.rms_beam_err);
            v
        })
        .collect();
    let spread = found.spread.as_ref();
    // Warnings go to stderr as well, so a script that keeps only stdout still shows them.
    let ranked = ranked(warnings(found, names));
    for w in ranked.iter().take(SHOWN_WARNINGS) {
        eprintln!("warning: {w}");
    }
    if let Some(more) = more_line(&ranked) {
        eprintln!("{more}");
    }
    let warnings: Vec<String> = ranked.iter().map(Warning::to_string).collect();
    println!(
        "{}",
        json!({"method": a.method, "split": found.split, "steps": steps, "identified": fm, "guess": gm, "logs": logs,
               "uncertainty": spread.map(|s| &s.0),
               "tradeoffs": spread.map(|s| &s.1),
               "each_log": each_log_json(&found.each_log, names),
               "ringing": found.ringing,
               "warnings": warnings})
    );
}

/// Each log calibrated alone (empty with one log): its parameters with their intervals, or
/// the error.
fn each_log_json(each: &[LogAlone], names: &[String]) -> Vec<serde_json::Value> {
    each.iter()
        .zip(names)
        .map(|(r, name)| match r {
            LogAlone::Fitted(errs) => json!({"log": name, "uncertainty": errs}),
            LogAlone::Failed(e) => json!({"log": name, "error": e}),
        })
        .collect()
}

fn print_text(
    a: &CalibrateArgs,
    found: &Calibration,
    exps: &[Experiment],
    names: &[String],
    (fm, gm): (serde_json::Value, serde_json::Value),
) {
    println!(
        "calibrated from {} log(s) by the {} method, guess: {}",
        exps.len(),
        a.method,
        a.plant.source()
    );
    for ((e, f), name) in exps.iter().zip(&found.per_log).zip(names) {
        let w = &e.windows;
        println!(
            "  {name}: {} samples, move {:.3}..{:.3} s, settling to {:.3} s; fit: hub {:.2e} rad, {} {:.3} {} RMS",
            e.log.t.len(),
            w.start_s,
            w.end_s,
            w.settle_end_s,
            f.rms_theta_err_rad,
            e.log.sensor.name(),
            f.rms_beam_err,
            e.log.sensor.unit()
        );
    }
    for (r, name) in found.ringing.iter().zip(names) {
        println!("  {name}: {}", ringing_line(r));
    }
    for s in &found.steps {
        print_step(s);
    }
    if let Some(s) = &found.split {
        print_split(s);
    }
    print_spread(found, names);
    for (r, name) in found.each_log.iter().zip(names) {
        match r {
            LogAlone::Fitted(errs) => {
                let parts: Vec<String> = errs
                    .iter()
                    .map(|u| format!("{} {:.4e} +- {:.1e}", u.name, u.value, u.std_err))
                    .collect();
                println!("  {name} alone: {}", parts.join(", "));
            }
            LogAlone::Failed(e) => println!("  {name} alone: not calibrated ({e})"),
        }
    }
    println!("  identified: {fm}");
    println!("  guess was:  {gm}");
    if let Some(path) = &a.out {
        println!("  written to {} (use with --params)", path.display());
    }
    if let Some(path) = &a.plot {
        let all: Vec<String> = (0..exps.len())
            .map(|i| numbered(path, i).display().to_string())
            .collect();
        println!("  figures: {}", all.join(", "));
    }
}

/// A log's ringing after its move against the model's on the same hub, in words.
fn ringing_line(r: &LogRinging) -> String {
    let ring = |x: &Ringing| {
        format!(
            "{:.3} +- {:.3} Hz (damping {:.4} +- {:.4})",
            x.hz, x.hz_sigma, x.damping_ratio, x.damping_sigma
        )
    };
    match (r.log, r.model) {
        (Some(l), Some(m)) => format!(
            "rings after the move ({:.2}..{:.2} s) at {} by itself; the model on its hub at {} ({:+.2} %; first clamped mode {:.3} Hz)",
            l.from_s,
            l.to_s,
            ring(&l),
            ring(&m),
            100.0 * r.off().unwrap_or(0.0),
            r.model_clamped_hz
        ),
        _ if r.why_none == Some(NoRinging::TooShort) => format!(
            "no ringing measured after the move (under two cycles of it left in the log); the model's first clamped mode {:.3} Hz",
            r.model_clamped_hz
        ),
        _ => format!(
            "no ringing after the move; the model's first clamped mode {:.3} Hz",
            r.model_clamped_hz
        ),
    }
}

/// The split method's own figures: the beam's fit, the encoder, the torque balance.
fn print_split(s: &SplitReport) {
    println!(
        "  split, beam (hub prescribed): {} RMS error {:.3} {}, {} scale {:.4}",
        s.beam_signal,
        s.beam_rms_err,
        s.beam_unit,
        if s.beam_signal == BeamSensor::RootStrain.name() {
            "gauge"
        } else {
            "sensor"
        },
        s.sensors.gauge_scale
    );
    let steps: Vec<String> = s
        .encoder_step_rad
        .iter()
        .map(|q| match q {
            Some(q) => format!(
                "{q:.3e} rad ({:.0} counts a turn)",
                std::f64::consts::TAU / q
            ),
            None => "none (the angle is not on a grid)".into(),
        })
        .collect();
    if s.encoder_step_given {
        println!("  split, encoder step (given): {}", steps[0]);
    } else {
        println!(
            "  split, encoder step in each log's angle: {}",
            steps.join(", ")
        );
    }
    println!(
        "  split, torque balance over {} moving samples: RMS error {:.2e} of {:.2e} N m; {}; {}",
        s.balance_samples,
        s.balance_rms_err_nm,
        s.balance_rms_torque_nm,
        if s.reference == "density" {
            format!(
                "density given, torque scale found {:.4}",
                s.sensors.torque_scale
            )
        } else if s.reference == "tip_mass" {
            format!(
                "density from the tip masses' frequency shift, torque scale found {:.4}",
                s.sensors.torque_scale
            )
        } else {
            "torque taken to read true (scale 1): masses, EI and friction carry its scale error (--known-density, or logs with two --tip-masses, measure it)".into()
        },
        if s.offset_fitted {
            format!("torque offset {:.2e} N m", s.sensors.torque_offset_nm)
        } else {
            "no torque offset fitted".into()
        }
    );
    println!(
        "  split, check: the logged torque replayed open loop through the sensors drifts {:.2e} rad RMS from the logged angle",
        s.replay_rms_theta_err_rad
    );
}

/// The intervals, and the warnings about parameters the logs do not pin down.
fn print_spread(found: &Calibration, names: &[String]) {
    let split = &found.split;
    if let Some((errs, _)) = &found.spread {
        let parts: Vec<String> = errs
            .iter()
            .map(|u| format!("{} {:.4e} +- {:.1e}", u.name, u.value, u.std_err))
            .collect();
        let how = if let Some(s) = split {
            let [lo, hi] = beam_tools::identify::split::WINDOW_FACTORS;
            format!("one-sigma ({}: Gauss-Newton, correlated residuals counted; balance: block bootstrap; both with the shift from smoothing the hub over {lo:.1} or {hi:.1} times the width, and from quantising its angle again at other phases of the encoder's step)", s.beam_signal)
        } else {
            "one-sigma (noise only, near the result)".into()
        };
        println!("  {how}: {}", parts.join(", "));
    }
    let ranked = ranked(warnings(found, names));
    for w in ranked.iter().take(SHOWN_WARNINGS) {
        println!("  warning: {w}");
    }
    if let Some(more) = more_line(&ranked) {
        println!("  {more}");
    }
}

fn print_step(s: &StepReport) {
    let fitted: Vec<String> = s
        .fitted
        .iter()
        .map(|(n, v)| format!("{n} {v:.5e}"))
        .collect();
    println!(
        "  step {:18} {:.2}..{:.2} s: {}; RMS error hub {:.2e} rad, root strain {:.2} ue",
        s.name,
        s.window.0,
        s.window.1,
        fitted.join(", "),
        s.rms_theta_err_rad,
        s.rms_strain_err_ue
    );
}

/// Derived figures of the identified model and of the guess.
fn summary<const N: usize>(
    found: &BeamParams,
    guess: &BeamParams,
) -> anyhow::Result<(serde_json::Value, serde_json::Value)> {
    let describe = |p: &BeamParams| -> anyhow::Result<serde_json::Value> {
        let m = ModalModel::<N>::try_build(&Beam::try_build(*p)?)?;
        Ok(
            json!({"jm_kgm2": p.jm_kgm2, "density_kg_m3": p.density_kg_m3, "ei_nm2": p.ei_nm2, "viscous_nms": p.viscous_nms,
                  "coulomb_nm": p.coulomb_nm, "coulomb_asym_nm": p.coulomb_asym_nm, "damping_ratio": p.damping_ratio, "root_gauge_m": p.root_gauge_m,
                  "mtt": m.mtt, "jeff": m.jeff, "clamped_hz": m.clamped_hz.to_vec(), "pinned_hz": m.pinned_hz.to_vec()}),
        )
    };
    Ok((describe(found)?, describe(guess)?))
}

fn uncertainty_n<const N: usize>(p: &BeamParams, exps: &[Experiment]) -> Option<Spread> {
    beam_tools::identify::calibrate::uncertainty::<N>(p, exps)
}

fn log_fits<const N: usize>(
    p: &BeamParams,
    sensors: &Sensors,
    exps: &[Experiment],
) -> anyhow::Result<Vec<LogFit>> {
    let seen: Vec<Experiment> = exps
        .iter()
        .map(|e| Experiment {
            log: beam_tools::identify::replay::corrected(&e.log, sensors),
            ..e.clone()
        })
        .collect();
    let mut fits = beam_tools::identify::calibrate::log_fits::<N>(p, &seen)
        .context("the model broke down on a log")?;
    // The beam's error as its sensor reads it.
    fits.iter_mut()
        .for_each(|f| f.rms_beam_err *= sensors.gauge_scale);
    Ok(fits)
}

/// `path` for the first log, `stem-N.ext` for the N-th (from 2).
fn numbered(path: &std::path::Path, i: usize) -> PathBuf {
    if i == 0 {
        return path.to_path_buf();
    }
    let stem = path
        .file_stem()
        .map_or("plot".into(), |s| s.to_string_lossy());
    let ext = path.extension().map_or("".into(), |e| e.to_string_lossy());
    path.with_file_name(format!("{stem}-{}.{ext}", i + 1))
}

fn traces_n<const N: usize>(
    p: &BeamParams,
    sensors: &Sensors,
    log: &beam_tools::identify::calibrate::Log,
) -> anyhow::Result<beam_tools::identify::replay::Traces> {
    beam_tools::identify::replay::traces::<N>(p, sensors, log)
        .context("the model broke down on a log")
}

/// `--strain-delay S`: 0 to 0.5 s.
pub fn strain_delay_value(s: &str) -> Result<f64, String> {
    let v: f64 = s.trim().parse().map_err(|e| format!("`{s}`: {e}"))?;
    if (0.0..=0.5).contains(&v) {
        Ok(v)
    } else {
        Err(format!("{v} s is outside 0 to 0.5 s"))
    }
}
