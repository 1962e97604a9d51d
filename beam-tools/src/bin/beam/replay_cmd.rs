//! `beam replay`: a model against a log: the beam driven by the logged hub angle, the hub by
//! the logged torque, with the figures that say how well the model explains the log.

use crate::PlantArgs;
use anyhow::{bail, Context};
use beam_tools::identify::calibrate::{find_windows, read_log_with, Columns, Windows};
use beam_tools::identify::replay::{replay_report, sensor_lag, traces, Traces};
use beam_tools::io::params_file::Sensors;
use clap::Args;
use std::path::PathBuf;

#[derive(Args)]
pub struct ReplayArgs {
    /// The log (as `beam calibrate` reads it).
    log: PathBuf,
    /// The model: a preset or --params FILE (as `beam calibrate --out` writes), modes, payload.
    #[command(flatten)]
    plant: PlantArgs,
    /// Which column holds what, and its unit (as for `beam calibrate`).
    #[arg(long, value_name = "MAP", value_parser = Columns::parse)]
    columns: Option<Columns>,
    /// The windows, s from the log's first sample [default: found in the log].
    #[arg(long, value_name = "START,END,SETTLE_END", value_delimiter = ',')]
    windows: Option<Vec<f64>>,
    /// The beam sensor's delay behind the hub, s, taken out before the comparison (0: as
    /// logged) [default: the parameter file's `sensors.strain_delay_s` if it is above 0,
    /// else found on the model as `beam calibrate` finds it and taken out from 3 ms, said
    /// on stderr; the JSON's `strain_delay_s` is the one taken out].
    #[arg(long, value_name = "S", value_parser = crate::calibrate_cmd::strain_delay_value)]
    strain_delay: Option<f64>,
    /// Draw the model against the log: hub angle and rate (torque replay), root strain and,
    /// where logged, mid-span strain (hub prescribed), .png or .svg.
    #[arg(long, value_name = "FILE")]
    plot: Option<PathBuf>,
    /// Write the model against the log, sample by sample, as CSV: time, hub angle and rate
    /// (log, torque replay), root strain and, where logged, mid-span strain (log, hub
    /// prescribed).
    #[arg(long, value_name = "FILE")]
    csv: Option<PathBuf>,
    /// Print one JSON object.
    #[arg(long)]
    json: bool,
}

pub fn run(a: &ReplayArgs) -> anyhow::Result<()> {
    if let Some(path) = &a.plot {
        beam_tools::io::plot::check_extension(path)?;
    }
    if a.windows.as_ref().is_some_and(|w| w.len() != 3) {
        bail!("--windows takes three times: START,END,SETTLE_END");
    }
    let params = *crate::beam(&a.plant)?.params();
    let sensors = match &a.plant.params {
        Some(path) => beam_tools::io::params_file::load_with_sensors(path)?.1,
        None => Sensors::default(),
    };
    let file = a.log.display().to_string();
    let text = std::fs::read_to_string(&a.log).with_context(|| file.clone())?;
    let mut log = read_log_with(&text, &file, &a.columns.clone().unwrap_or_default())?;
    // The delay given, else the parameter file's (calibrate found it), else found here.
    let given = a
        .strain_delay
        .or((sensors.strain_delay_s > 0.0).then_some(sensors.strain_delay_s));
    let (delay, note) = with_modes!(a.plant.modes, sensor_lag(&params, &log, &file, given));
    if let Some(note) = &note {
        eprintln!("warning: {note}");
    }
    if delay > 0.0 {
        log = log.strain_advanced(delay);
    }
    let windows = match a.windows.as_deref() {
        Some([s, e, z]) => Windows::given(*s, *e, *z, &log),
        Some(_) => bail!("--windows takes three times: START,END,SETTLE_END"),
        None => find_windows(&log),
    }
    .with_context(|| file.clone())?;
    let report = with_modes!(a.plant.modes, report_n(&params, &sensors, &log, &windows))?;
    if a.csv.is_some() || a.plot.is_some() {
        let traces = with_modes!(a.plant.modes, traces_n(&params, &sensors, &log))?;
        if let Some(path) = &a.csv {
            beam_tools::io::files::write_atomically(path, |w| traces.write_csv(w))
                .with_context(|| path.display().to_string())?;
        }
        if let Some(path) = &a.plot {
            let title = format!("{} against {}", a.plant.source(), file);
            beam_tools::io::files::plot_atomically(path, |tmp| traces.plot(&title, tmp))?;
        }
    }
    if a.json {
        let mut v = serde_json::to_value(&report)?;
        v["windows_s"] = serde_json::json!([windows.start_s, windows.end_s, windows.settle_end_s]);
        v["strain_delay_s"] = serde_json::json!(delay);
        println!("{v}");
    } else {
        let hz = |f: Option<f64>| f.map_or("-".into(), |f| format!("{f:.3} Hz"));
        println!(
            "{}: move {:.3}..{:.3} s, settling to {:.3} s",
            file, windows.start_s, windows.end_s, windows.settle_end_s
        );
        println!(
            "  hub (logged torque, open loop): RMS error {:.3} deg",
            report.hub_rms_err_deg
        );
        println!(
            "  {} (logged hub angle): RMS error {:.3} {unit} of {:.3} {unit} RMS ({:.1} %)",
            report.beam_signal,
            report.beam_rms_err,
            report.beam_rms_measured,
            100.0 * report.beam_rel_err,
            unit = report.beam_unit
        );
        println!(
            "  vibration after the move: log {}, model {}{}",
            hz(report.freq_log_hz),
            hz(report.freq_model_hz),
            report
                .freq_note
                .as_ref()
                .map_or(String::new(), |n| format!(" ({n})"))
        );
    }
    Ok(())
}

fn report_n<const N: usize>(
    params: &model_core::BeamParams,
    sensors: &Sensors,
    log: &beam_tools::identify::calibrate::Log,
    windows: &Windows,
) -> anyhow::Result<beam_tools::identify::replay::ReplayReport> {
    replay_report::<N>(params, sensors, log, windows)
        .context("the model broke down replaying this log (or its parameters are invalid)")
}

fn traces_n<const N: usize>(
    params: &model_core::BeamParams,
    sensors: &Sensors,
    log: &beam_tools::identify::calibrate::Log,
) -> anyhow::Result<Traces> {
    traces::<N>(params, sensors, log).context("the model broke down")
}
