//! `beam`: the command line of the slewing-beam toolchain.
//!
//! - `beam model`: the modal model of a preset (matrices, clamped and pinned frequencies).
//! - `beam simulate`: the paper's slew in closed loop with the model-core controller; the
//!   metrics, and optionally the trace as CSV and the paper's figures as a plot.
//! - `beam optimize`: gain design by constrained optimisation of the paper's cost J,
//!   optionally written into the gain table.
//! - `beam calibrate`: the model's parameters from a logged PD slew.
//! - `beam sweep`: Monte Carlo over parameter errors and payloads, against the PD baseline.
//! - `beam pil`: the slew with the PIL firmware under QEMU as the drive.
//! - `beam telemetry`: a drive's defmt telemetry as the CSV `beam calibrate` reads.
//! - `beam drive`: a script of commands for a commanded drive (board, PIL firmware or host).
//! - `beam replay`: a model against a log (hub prescribed, and torque open loop).
//! - `beam flash`: the board's firmware, as built, through a debug probe.
//!
//! `--json` prints one JSON object on stdout. Every error prints one line on stderr and
//! exits with code 2; `beam drive` exits with code 1 when the drive refused a command (after
//! printing every exchange).
#![forbid(unsafe_code)]

/// Calls `$f::<N>` with the runtime mode count `$n` (1 to 4) as a const generic.
macro_rules! with_modes {
    ($n:expr, $f:ident ( $($arg:expr),* )) => {
        match $n {
            1 => $f::<1>($($arg),*),
            2 => $f::<2>($($arg),*),
            3 => $f::<3>($($arg),*),
            _ => $f::<4>($($arg),*),
        }
    };
}

mod calibrate_cmd;
mod drive_cmd;
mod flash_cmd;
mod model_cmd;
mod optimize_cmd;
mod pil_cmd;
mod replay_cmd;
mod simulate_cmd;
mod sweep_cmd;
mod telemetry_cmd;

use anyhow::{bail, Context};
use beam_sim::metrics::{metrics_with, SettleSpec};
use beam_sim::sim::{Motion, SimOptions, SimResult, Via};
use beam_tools::io::{files as io, plot};
use clap::{Args, Parser, Subcommand};
use model_core::law::Setting;
use model_core::{Beam, BeamParams, Law, LawKind, Preset, Shaper, ShaperKind, Switching, Timing};

use serde_json::json;
use std::path::PathBuf;
use std::process::ExitCode;

#[derive(Parser)]
#[command(
    name = "beam",
    version,
    about = "Sliding-mode control of a slewing flexible beam: model and simulation"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Print the modal model of a preset: matrices and frequencies.
    Model(model_cmd::ModelArgs),
    /// Simulate the paper's slew (-90 to +90 deg in 0.35 s) in closed loop.
    Simulate(simulate_cmd::SimulateArgs),
    /// Design gains by constrained optimisation of the paper's cost J.
    Optimize(optimize_cmd::OptimizeArgs),
    /// Identify the model's parameters from a logged PD slew (CSV).
    Calibrate(calibrate_cmd::CalibrateArgs),
    /// Monte Carlo robustness: parameter errors and payloads, SMC against the PD baseline.
    Sweep(sweep_cmd::SweepArgs),
    /// The paper's slew with the PIL firmware under QEMU as the drive (processor in the loop).
    Pil(pil_cmd::PilArgs),
    /// Turn a drive's defmt telemetry into the CSV `beam calibrate` reads.
    Telemetry(telemetry_cmd::TelemetryArgs),
    /// Command a drive: moves, waypoints, payload, stop, fault clearing, status, from a
    /// script (`move DEG [S]`, `through DEG,DEG [S]`, `payload KG`, `stop`, `disable`,
    /// `clear`, `status`, `stream N`, `wait S`, `done [S]`; on the simulated beam also
    /// `attach KG`, `fault N`, `load NM`, `sensor gauge|encoder FAULT`, `latency N`; one per
    /// line), on the PIL firmware under QEMU (--pil) or the host (--sim).
    Drive(drive_cmd::DriveArgs),
    /// A model against a log: the beam driven by the logged hub angle, the hub by the logged
    /// torque; RMS errors and the vibration frequency in both.
    Replay(replay_cmd::ReplayArgs),
    /// Flash the board's firmware as `cargo fw` last built it, through a debug probe
    /// (probe-rs), and run it with its telemetry printed. It never rebuilds.
    Flash(flash_cmd::FlashArgs),
}

/// One of beam-kinds' named enums, for clap: its names are the possible values, with help.
trait Named: Copy + Send + Sync + std::str::FromStr + 'static {
    const ALL: &'static [Self];
    fn name(self) -> &'static str;
    fn help(self) -> &'static str;
}

macro_rules! named {
    ($($t:ty),*) => {$(
        impl Named for $t {
            const ALL: &'static [Self] = <$t>::ALL;
            fn name(self) -> &'static str {
                <$t>::name(self)
            }
            fn help(self) -> &'static str {
                <$t>::help(self)
            }
        }
    )*};
}
named!(LawKind, Switching, Preset, ShaperKind);

/// The value parser of a [`Named`] argument: `--controller smc-strain`, `--preset aluminium`.
/// `LO,HI`: a range of modal damping ratios, `0 < LO <= HI < 1` (`--damping-ratio` of `sweep`
/// and `optimize --robust`).
fn damping_range(text: &str) -> Result<(f64, f64), String> {
    let (lo, hi) = text
        .split_once(',')
        .ok_or("expected LO,HI, for instance 0.005,0.02 (0.5 to 2 %)")?;
    let ratio = |v: &str| {
        v.trim()
            .parse::<f64>()
            .map_err(|e| format!("{v:?} is not a number: {e}"))
    };
    let (lo, hi) = (ratio(lo)?, ratio(hi)?);
    if !(lo > 0.0 && lo <= hi && hi < 1.0) {
        return Err(format!(
            "{lo},{hi}: damping ratios must satisfy 0 < LO <= HI < 1 (0.005,0.02 is 0.5 to 2 %)"
        ));
    }
    Ok((lo, hi))
}

fn named<T: Named>() -> impl clap::builder::TypedValueParser<Value = T>
where
    T::Err: std::error::Error + Send + Sync + 'static,
{
    use clap::builder::{PossibleValue, PossibleValuesParser, TypedValueParser};
    PossibleValuesParser::new(
        T::ALL
            .iter()
            .map(|v| PossibleValue::new(v.name()).help(v.help())),
    )
    .try_map(|s| s.parse::<T>())
}

#[derive(Args, Clone)]
struct PlantArgs {
    /// Parameter preset.
    #[arg(long, value_parser = named::<Preset>(), default_value = "aluminium")]
    preset: Preset,
    /// Number of flexible modes, 1 to 4.
    #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u8).range(1..=4))]
    modes: u8,
    /// Parameters from a file (as `beam calibrate --out` writes), instead of --preset.
    #[arg(long, value_name = "FILE")]
    params: Option<PathBuf>,
    /// Tip (payload) mass, kg.
    #[arg(
        long,
        value_name = "KG",
        visible_alias = "payload",
        allow_negative_numbers = true
    )]
    tip_mass: Option<f64>,
}

impl PlantArgs {
    /// The `preset` of a report: the preset's name, or the parameter file's path when the
    /// parameters come from a file (the preset is then not used).
    fn preset_label(&self) -> String {
        match &self.params {
            Some(path) => path.display().to_string(),
            None => self.preset.name().to_string(),
        }
    }

    /// What the parameters are: the file's path, or the preset's name.
    fn source(&self) -> String {
        match &self.params {
            Some(path) => path.display().to_string(),
            None => format!("{} preset", self.preset.name()),
        }
    }
}

/// The move, planned by model-core: a quintic, optionally shaped.
#[derive(Args)]
pub(crate) struct MoveArgs {
    /// Move to this hub angle, deg [default: the paper's slew, -90 to +90 deg].
    #[arg(long = "move", value_name = "TO_DEG", allow_negative_numbers = true)]
    to_deg: Option<f64>,
    /// Start of the move, deg (where the hub rests before it).
    #[arg(long = "from", value_name = "DEG", allow_negative_numbers = true, default_value_t = -90.0)]
    from_deg: f64,
    /// Duration of the (base) move, s, or `shortest`: the shortest time model-core's planner
    /// allows (rigid-body torque within 60 % of the limit, speed within 20 rad/s).
    #[arg(
        long = "time",
        value_name = "S|shortest",
        default_value = "0.35",
        allow_negative_numbers = true,
        value_parser = parse_move_time
    )]
    time: MoveTime,
    /// With `--time shortest` and an observer law: plan the move to leave the law's
    /// reference beam at rest, a bang-coast-bang move shaped on it by Newton's method
    /// (docs/design.md, section 3), instead of the shaped quintic.
    #[arg(long)]
    exact: bool,
    /// Pass through these hub angles on the way to --move, deg (at most 7; planned by
    /// model-core's planner, as the drive does).
    #[arg(
        long,
        value_name = "DEG,...",
        value_delimiter = ',',
        allow_negative_numbers = true
    )]
    via: Vec<f64>,
    /// Input shaper on the reference [default: the gain table's for the law, else none].
    #[arg(long, value_parser = named::<ShaperKind>())]
    shaper: Option<ShaperKind>,
    /// The shaped mode's frequency, Hz (optimize: the search's start is not used; the
    /// frequency is searched).
    #[arg(long, value_name = "HZ", allow_negative_numbers = true)]
    shaper_hz: Option<f32>,
    /// The shaped mode's damping ratio.
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    shaper_damping: f32,
    /// EI: the residual vibration allowed at the design frequency (fraction).
    #[arg(long, default_value_t = 0.05, allow_negative_numbers = true)]
    shaper_tolerance: f32,
    /// Shorten the base quintic so the shaped move still ends at --time.
    #[arg(long)]
    end_on_time: bool,
}

/// A move's `--time`: seconds, or the shortest the planner allows.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum MoveTime {
    Seconds(f64),
    Shortest,
}

fn parse_move_time(s: &str) -> Result<MoveTime, String> {
    if s == "shortest" {
        return Ok(MoveTime::Shortest);
    }
    s.parse()
        .map(MoveTime::Seconds)
        .map_err(|_| format!("`{s}` is neither a number of seconds nor `shortest`"))
}

impl MoveArgs {
    /// The move, checked, with the shaper given or `table` (the gain table's for the law)
    /// when none is. `hz_default` stands in for a missing --shaper-hz (optimize).
    pub(crate) fn motion(&self, hz_default: Option<f32>, table: Shaper) -> anyhow::Result<Motion> {
        let to = self.to_deg.unwrap_or(90.0);
        for (flag, v) in [("--move", to), ("--from", self.from_deg)] {
            if !(v.is_finite() && v.abs() <= 3600.0) {
                bail!("{flag} {v} must be an angle within +-3600 deg");
            }
        }
        let (time_s, shortest) = match self.time {
            MoveTime::Seconds(t) if t.is_finite() && t > 0.0 && t <= 60.0 => (t, false),
            MoveTime::Seconds(t) => {
                bail!("--time {t} must be a number of seconds in (0, 60], or `shortest`")
            }
            MoveTime::Shortest => (0.0, true),
        };
        if self.exact && !(shortest && self.via.is_empty()) {
            bail!(
                "--exact plans the shortest move to a target: give --time shortest, and no --via"
            );
        }
        if self
            .via
            .iter()
            .any(|v| !(v.is_finite() && v.abs() <= 3600.0))
        {
            bail!("--via takes angles within +-3600 deg");
        }
        let via_rad: Vec<f32> = self.via.iter().map(|d| d.to_radians() as f32).collect();
        let Some(via) = Via::new(&via_rad) else {
            bail!(
                "--via takes at most {} angles",
                model_core::planner::MAX_WAYPOINTS - 1
            );
        };
        let shaper = match (self.shaper, self.shaper_hz.or(hz_default)) {
            (None, None) => table,
            (None, Some(_)) if self.shaper_hz.is_some() => bail!("--shaper-hz needs a --shaper"),
            (None, Some(_)) => table,
            (Some(kind), hz) => match (kind, hz) {
                (ShaperKind::None, None) => Shaper::NONE,
                (ShaperKind::None, Some(_)) if self.shaper_hz.is_some() => {
                    bail!("--shaper-hz needs a --shaper")
                }
                (ShaperKind::None, Some(_)) => Shaper::NONE,
                (kind, None) => bail!("--shaper {kind} needs --shaper-hz"),
                (kind, Some(freq_hz)) => Shaper {
                    kind,
                    freq_hz,
                    damping: self.shaper_damping,
                    tolerance: self.shaper_tolerance,
                },
            },
        };
        let timing = if self.end_on_time {
            Timing::EndOnTime
        } else {
            Timing::Stretch
        };
        // The defaults (-90, 90 deg, 0.35 s) convert to exactly the f32 constants of
        // model-core's `paper_slew`, so the paper's slew needs no special case.
        let motion = Motion {
            from_rad: self.from_deg.to_radians() as f32,
            to_rad: to.to_radians() as f32,
            time_s: time_s as f32,
            shaper,
            timing,
            via,
            shortest,
            exact: self.exact,
        };
        // A single timed move is checked here; the planner's moves need the drive's model
        // for their limits and are checked when they are planned.
        if !motion.needs_planner() {
            motion.quintic()?;
        }
        Ok(motion)
    }
}

/// What counts as settled: the bands of `settle_s`, the time from the move command after which
/// the hub stays near the target and the beam still.
#[derive(Args, Clone, Copy)]
struct SettleArgs {
    /// Settle band on the hub angle around the target, deg.
    #[arg(long, value_name = "DEG", default_value_t = SettleSpec::default().hub_deg)]
    settle_hub_deg: f64,
    /// Settle band on the root strain around zero, microstrain.
    #[arg(long, value_name = "UE", default_value_t = SettleSpec::default().strain_ue)]
    settle_strain_ue: f64,
}

impl SettleArgs {
    /// The bands, checked.
    fn spec(&self) -> anyhow::Result<SettleSpec> {
        let spec = SettleSpec {
            hub_deg: self.settle_hub_deg,
            strain_ue: self.settle_strain_ue,
        };
        spec.check()
            .map_err(|e| anyhow::anyhow!("--settle-hub-deg/--settle-strain-ue: {e}"))?;
        Ok(spec)
    }
}

/// What the simulated sensors resolve, in place of the gain table's: what `simulate` and
/// `sweep` take to show what each sensor costs a law (its observer's estimate against the
/// beam's true state, `--true-state`).
#[derive(Args, Clone, Copy)]
struct SensorArgs {
    /// The encoder's counts per revolution (after quadrature decoding) in place of the gain
    /// table's `[drive]`: the simulated encoder, the drive's decoding of it and the observer
    /// laws' designs all take it, as a drive whose table names that encoder does (designed
    /// no finer than the reference encoder resolves). Its counter (the table's
    /// `encoder_counter_bits`) must still keep count at the drive's 50 rad/s.
    #[arg(long, value_name = "N")]
    encoder_counts: Option<u32>,
    /// The simulated root gauge's noise, microstrain RMS [default: 0.5], in (0, 1000]. The
    /// observer laws stay designed on the noise they assume (0.6 ue), as a drive that does
    /// not know its gauge is noisier would be. Not 0: a converter's code that never moves
    /// is what the drive's monitor takes for a stuck gauge.
    #[arg(long, value_name = "UE", allow_negative_numbers = true)]
    gauge_noise_ue: Option<f64>,
}

impl SensorArgs {
    /// `instruments` with the encoder given, checked.
    fn instruments(
        &self,
        instruments: model_core::Instruments,
    ) -> anyhow::Result<model_core::Instruments> {
        let Some(counts) = self.encoder_counts else {
            return Ok(instruments);
        };
        if counts == 0 {
            bail!("--encoder-counts must be > 0");
        }
        let encoder = model_core::EncoderSpec {
            counts_per_rev: counts,
            ..instruments.encoder
        };
        gain_table::encoder_reads_the_hub(&encoder)
            .map_err(|m| anyhow::anyhow!("--encoder-counts {counts}: {m}"))?;
        Ok(model_core::Instruments {
            encoder,
            ..instruments
        })
    }

    /// The gauge's noise, strain, checked.
    fn strain_noise_std(&self) -> anyhow::Result<f64> {
        match self.gauge_noise_ue {
            None => Ok(beam_sim::sensors::STRAIN_NOISE_STD),
            Some(ue) if ue.is_finite() && ue > 0.0 && ue <= 1000.0 => Ok(ue * 1e-6),
            Some(ue) => bail!("--gauge-noise-ue {ue} must be in (0, 1000] microstrain"),
        }
    }

    /// `sensors` with the encoder and the gauge's noise given, checked.
    fn sensors(
        &self,
        sensors: beam_sim::sensors::SensorConfig,
    ) -> anyhow::Result<beam_sim::sensors::SensorConfig> {
        let instruments = self.instruments(sensors.instruments())?;
        Ok(beam_sim::sensors::SensorConfig {
            encoder: instruments.encoder,
            adc: instruments.adc,
            strain_noise_std: self.strain_noise_std()?,
            ..sensors
        })
    }
}

/// What `simulate` and `pil` share: how long, which noise, what to write.
#[derive(Args)]
struct RunArgs {
    #[command(flatten)]
    settle: SettleArgs,
    /// Simulated time after the move starts, s.
    #[arg(long, default_value_t = 2.0)]
    duration: f64,
    /// Seed of the sensor noise.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Write the trace as CSV.
    #[arg(long, value_name = "FILE")]
    csv: Option<PathBuf>,
    /// Write the paper's figures 2-5 (.png or .svg).
    #[arg(long, value_name = "FILE")]
    plot: Option<PathBuf>,
    /// Print one JSON object.
    #[arg(long)]
    json: bool,
}

impl RunArgs {
    /// The run's options, checked before anything runs (the plot's format too).
    fn options(&self) -> anyhow::Result<SimOptions> {
        if !(self.duration.is_finite() && self.duration > 0.0 && self.duration <= 3600.0) {
            bail!(
                "--duration {} must be a number of seconds in (0, 3600]",
                self.duration
            );
        }
        if let Some(path) = &self.plot {
            plot::check_extension(path)?;
        }
        self.settle.spec()?;
        Ok(SimOptions {
            duration_s: self.duration,
            sensors: beam_sim::sensors::SensorConfig {
                seed: self.seed,
                ..Default::default()
            },
            ..SimOptions::default()
        })
    }

    /// Writes the trace CSV and the figures, if asked for.
    fn write(&self, run: &SimResult, title: &str) -> anyhow::Result<()> {
        if let Some(path) = &self.csv {
            io::write_atomically(path, |w| io::write_trace_csv(run, w))
                .with_context(|| path.display().to_string())?;
        }
        if let Some(path) = &self.plot {
            io::plot_atomically(path, |tmp| plot::plot(run, title, tmp))?;
            // On stderr, so that --json's standard output stays one object.
            eprintln!("figures written to {}", path.display());
        }
        Ok(())
    }
}

/// The run's metrics as a JSON object with what was run: the `--json` output's common part.
fn run_json(
    run: &SimResult,
    law: &Law,
    preset: &str,
    modes: u8,
    settle: &SettleSpec,
) -> anyhow::Result<serde_json::Map<String, serde_json::Value>> {
    let v = serde_json::to_value(metrics_with(run, settle))?;
    let serde_json::Value::Object(mut o) = v else {
        bail!("metrics are not an object");
    };
    let reason = run.breakdown.as_ref().map(|(_, why)| why.to_string());
    o.insert("preset".into(), json!(preset));
    o.insert("modes".into(), json!(modes));
    o.insert("controller".into(), json!(law.name()));
    o.insert("gains".into(), gains_json(law));
    o.insert("breakdown_reason".into(), json!(reason));
    o.insert("settle_band".into(), json!(settle));
    o.insert("faults".into(), json!(run.faults.to_string()));
    o.insert("move_end_s".into(), json!(run.move_end_s));
    Ok(o)
}

/// Exit status when the reader of standard output went away (`beam ... | head`): what a
/// process killed by SIGPIPE reports to a shell (128 + 13).
const BROKEN_PIPE_EXIT: i32 = 141;

/// A reader that closed standard output early ends the run quietly: Rust ignores SIGPIPE,
/// so `println!` panics on the closed pipe, and this hook turns that one panic into the exit
/// a pipe's writer is expected to make. Every other panic reports as before.
fn quiet_on_a_closed_pipe() {
    let default = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| {
        let payload = info.payload();
        let message = payload
            .downcast_ref::<String>()
            .map(String::as_str)
            .or_else(|| payload.downcast_ref::<&str>().copied())
            .unwrap_or("");
        if message.starts_with("failed printing to stdout") && message.contains("Broken pipe") {
            std::process::exit(BROKEN_PIPE_EXIT);
        }
        default(info)
    }));
}

fn main() -> ExitCode {
    quiet_on_a_closed_pipe();
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) => {
            use clap::error::ErrorKind;
            if matches!(
                e.kind(),
                ErrorKind::DisplayHelp
                    | ErrorKind::DisplayVersion
                    | ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand
            ) {
                e.exit();
            }
            // One line, like every other error: clap's first paragraph (which names a
            // missing argument on its second line) without the usage block after it.
            let text = e.to_string();
            let first: Vec<&str> = text
                .lines()
                .take_while(|l| !l.trim().is_empty())
                .map(str::trim)
                .collect();
            let first = if first.is_empty() {
                "invalid arguments".to_string()
            } else {
                first.join(" ")
            };
            eprintln!(
                "beam: {} (see beam --help)",
                first.trim_start_matches("error: ")
            );
            return ExitCode::from(2);
        }
    };
    let result = match cli.command {
        Command::Model(a) => model_cmd::run_model(&a),
        Command::Simulate(a) => simulate_cmd::run_simulate(&a),
        Command::Optimize(a) => optimize_cmd::run(&a),
        Command::Sweep(a) => sweep_cmd::run(&a),
        Command::Calibrate(a) => calibrate_cmd::run(&a),
        Command::Pil(a) => pil_cmd::run(&a),
        Command::Telemetry(a) => telemetry_cmd::telemetry(&a),
        Command::Drive(a) => drive_cmd::run(&a),
        Command::Replay(a) => replay_cmd::run(&a),
        Command::Flash(a) => flash_cmd::run(&a),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) if e.downcast_ref::<drive_cmd::Refused>().is_some() => {
            eprintln!("beam: {e}");
            ExitCode::from(1)
        }
        Err(e) => {
            // The error and its causes, `outer: inner`, on one line whatever the source's
            // message looks like (TOML's spans several).
            let text = format!("{e:#}");
            let line: Vec<&str> = text
                .lines()
                .map(str::trim)
                .filter(|l| !l.is_empty())
                .collect();
            eprintln!("beam: error: {}", line.join("; "));
            ExitCode::from(2)
        }
    }
}

fn beam(plant: &PlantArgs) -> anyhow::Result<Beam> {
    let mut params: BeamParams = match &plant.params {
        Some(path) => beam_tools::io::params_file::load(path)?,
        None => BeamParams::preset(plant.preset),
    };
    if let Some(m) = plant.tip_mass {
        params.tip_mass_kg = m;
    }
    Beam::try_build(params).map_err(anyhow::Error::from)
}

fn gains_json(law: &Law) -> serde_json::Value {
    // An f32 gain printed through f64 would show 0.1 as 0.10000000149011612: go by its
    // shortest decimal form instead.
    let f = beam_sim::decimal::f32_decimal;
    let kind = law.kind();
    let mut out = serde_json::Map::new();
    for (name, v) in kind.gain_names().iter().zip(law.values()) {
        out.insert((*name).into(), json!(f(v)));
    }
    let s = law.settings();
    for setting in kind.settings() {
        let v = match setting {
            Setting::Switching => json!(s.switching.name()),
            Setting::ModelTerms => json!(s.model_terms),
        };
        out.insert(setting.name().into(), v);
    }
    serde_json::Value::Object(out)
}

fn print_summary(run: &SimResult, law: &Law, preset: &str, modes: u8, settle: &SettleSpec) {
    let m = &metrics_with(run, settle);
    let reason = run.breakdown.as_ref().map(|(_, why)| why.to_string());
    let reason = reason.as_deref();
    println!(
        "{} slew on the {preset} preset, {modes} mode(s), gains {}",
        law.name(),
        gains_json(law)
    );
    if let (Some((t, _)), Some(why)) = (&run.breakdown, reason) {
        println!("  MODEL BREAKDOWN at t = {t:.3} s: {why}");
        println!("  no metrics are reported for a run outside the model's range");
        return;
    }
    let show = |v: Option<f64>, unit: &str| {
        v.map_or("n/a (run too short)".to_string(), |v| {
            format!("{v:.4} {unit}")
        })
    };
    let end = run.samples.last().map_or(0.0, |x| x.t);
    let t = run.move_end_s;
    // The headline first: needs no window, so it compares moves of any length.
    println!(
        "  settled (hub {} deg, strain {} ue) {}  from the move command",
        settle.hub_deg,
        settle.strain_ue,
        m.settle_s.map_or(
            format!("never within the {end:.3} s run (try a longer --duration)"),
            |v| format!("at {v:.3} s")
        )
    );
    println!("  the move's reference ends at T = {t:.3} s");
    println!(
        "  peak torque                    {}",
        show(m.peak_torque_nm, "N m")
    );
    println!(
        "  peak root strain, whole run    {}",
        show(m.peak_root_strain_ue, "ue")
    );
    println!(
        "  max tracking error 0..T        {}",
        show(m.max_track_err_deg, "deg")
    );
    println!(
        "  hub error at T + 0.25 s        {}",
        show(m.err_deg_end_plus_0_25, "deg")
    );
    println!(
        "  RMS root strain T+0.05..T+0.25 {}",
        show(m.rms_root_strain_ue_end_plus_0_05_0_25, "ue")
    );
    println!(
        "  max root strain after T        {}",
        show(m.max_root_strain_ue_after_move, "ue")
    );
    println!(
        "  max mid strain after T         {}",
        show(m.max_mid_strain_ue_after_move, "ue")
    );
    println!(
        "  hub error at 2.0 s             {}",
        show(m.err_deg_t2_0, "deg")
    );
    println!("  the paper's figures, on its absolute windows:");
    println!(
        "    hub error at 0.6 s           {}",
        show(m.err_deg_t0_6, "deg")
    );
    println!(
        "    RMS root strain 0.4..0.6 s   {}",
        show(m.rms_root_strain_ue_0_4_0_6, "ue")
    );
    println!("    cost J (W1 1, W2 10)         {}", show(m.cost_j, ""));
    println!("  faults                         {}", run.faults);
}
