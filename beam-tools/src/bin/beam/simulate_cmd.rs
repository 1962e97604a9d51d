//! `beam simulate`: a move in closed loop with model-core's controller on the simulated
//! beam, with the gains, shaper and instruments of a gain table or given on the command line;
//! the metrics, and optionally the trace and the figures.

use crate::{beam, named, print_summary, run_json, MoveArgs, PlantArgs, RunArgs, SensorArgs};
use anyhow::{anyhow, bail};
use beam_sim::sensors::SensorConfig;
use beam_sim::sim::{simulate, FaultKind, Injection, SimOptions, SimResult};
use beam_tools::io::table_file;
use clap::Args;
use model_core::law::Setting;
use model_core::{Beam, DriveTable, Law, LawKind, ModalModel, Shaper, Switching};
use serde_json::json;
use std::path::PathBuf;

/// `--gain NAME=VALUE`: a gain by its name (checked against the law's gains later).
pub(crate) fn gain_value(s: &str) -> Result<(String, f32), String> {
    let (name, value) = s
        .split_once('=')
        .ok_or_else(|| format!("`{s}`: expected NAME=VALUE, for example w=12"))?;
    let v: f32 = value
        .trim()
        .parse()
        .map_err(|e| format!("`{value}`: {e}"))?;
    Ok((name.trim().to_string(), v))
}

#[derive(Args)]
pub(crate) struct SimulateArgs {
    #[command(flatten)]
    plant: PlantArgs,
    /// The gain table the gains, the shaper and the drive's instruments come from [default:
    /// $BEAM_GAIN_TABLE, else the repository's gains.toml; without one, each law's
    /// starting gains, no shaper and the reference instruments].
    #[arg(long, value_name = "FILE")]
    table: Option<PathBuf>,
    /// Control law.
    #[arg(long, value_parser = named::<LawKind>(), default_value = "smc")]
    controller: LawKind,
    /// Feed an observer law (lqg, smc-modal) the beam's true state instead of its
    /// observer's estimate: what the law would do with perfect knowledge of the state, to
    /// see what the observer costs (refused for the other laws).
    #[arg(long)]
    true_state: bool,
    #[command(flatten)]
    sensors: SensorArgs,
    /// PD proportional gain, N m/rad.
    #[arg(long, allow_negative_numbers = true)]
    kp: Option<f32>,
    /// PD derivative gain, N m s/rad.
    #[arg(long, allow_negative_numbers = true)]
    kd: Option<f32>,
    /// SMC surface slope W, 1/s.
    #[arg(long, allow_negative_numbers = true)]
    w: Option<f32>,
    /// SMC switching gain A, rad/s^2.
    #[arg(long, allow_negative_numbers = true)]
    a: Option<f32>,
    /// SMC boundary-layer slope beta, s/rad.
    #[arg(long, allow_negative_numbers = true)]
    beta: Option<f32>,
    /// Strain blend c of smc-strain, rad per unit strain.
    #[arg(long, allow_negative_numbers = true)]
    c: Option<f32>,
    /// Switching function [default: the gain table's, else tanh].
    #[arg(long, value_parser = named::<Switching>())]
    switching: Option<Switching>,
    /// smc-strain: keep the model terms with q estimated from the root strain.
    #[arg(long)]
    model_terms: bool,
    /// smc-i: integral slope Wi, 1/s^2.
    #[arg(long, allow_negative_numbers = true)]
    wi: Option<f32>,
    /// lqg: integral weight, N m/(rad s).
    #[arg(long, allow_negative_numbers = true)]
    ki: Option<f32>,
    /// lqg: weight on the beam's vibration energy, (N m)^2/J.
    #[arg(long, allow_negative_numbers = true)]
    kq: Option<f32>,
    /// lqg: disturbance torque the observer assumes, N m.
    #[arg(long, allow_negative_numbers = true)]
    sigma: Option<f32>,
    /// Any gain of the law by its name (as in gains.toml), NAME=VALUE; repeatable.
    #[arg(long, value_name = "NAME=VALUE", value_parser = gain_value, allow_negative_numbers = true)]
    gain: Vec<(String, f32)>,
    #[command(flatten)]
    motion: MoveArgs,
    #[command(flatten)]
    load: LoadArgs,
    #[command(flatten)]
    run: RunArgs,
}

/// A step load on the hub (to test how the drive holds).
#[derive(Args)]
pub(crate) struct LoadArgs {
    /// Load torque on the hub, N m.
    #[arg(
        long,
        value_name = "NM",
        allow_negative_numbers = true,
        requires = "load_at"
    )]
    load_nm: Option<f64>,
    /// When the load is applied, s after the move starts.
    #[arg(
        long,
        value_name = "S",
        requires = "load_nm",
        allow_negative_numbers = true
    )]
    load_at: Option<f64>,
    /// When it is removed, s [default: never, within the run].
    #[arg(
        long,
        value_name = "S",
        requires = "load_nm",
        allow_negative_numbers = true
    )]
    load_until: Option<f64>,
}

impl LoadArgs {
    /// The load as an injection, checked.
    fn injection(&self) -> anyhow::Result<Option<Injection>> {
        let (Some(nm), Some(at_s)) = (self.load_nm, self.load_at) else {
            return Ok(None);
        };
        let until = self.load_until.unwrap_or(f64::INFINITY);
        if !(nm.is_finite() && nm.abs() <= 100.0) {
            bail!("--load-nm {nm} must be within +-100 N m");
        }
        if !(at_s.is_finite() && at_s >= 0.0 && until > at_s) {
            bail!("--load-at {at_s} must be >= 0 and before --load-until");
        }
        Ok(Some(Injection {
            kind: FaultKind::LoadTorque {
                nm,
                for_s: until - at_s,
            },
            at_s,
        }))
    }
}

pub(crate) fn law(a: &SimulateArgs, table: Option<&DriveTable>) -> anyhow::Result<Law> {
    let kind = a.controller;
    let reject = |flag: &str| anyhow!("--{flag} does not apply to --controller {kind}");
    // Gains not given on the command line come from the gain table (at the configured
    // payload), or the law's starting gains if there is none or it has no row for this law.
    // Each flag is the gain of that name in the law's specs.
    let base = default_law(table, kind, a.plant.tip_mass);
    let mut values = base.values();
    let named = [
        ("kp", a.kp),
        ("kd", a.kd),
        ("w", a.w),
        ("a", a.a),
        ("beta", a.beta),
        ("c", a.c),
        ("wi", a.wi),
        ("ki", a.ki),
        ("kq", a.kq),
        ("sigma", a.sigma),
    ];
    let given = named
        .iter()
        .filter_map(|&(name, v)| Some((name, v?)))
        .chain(a.gain.iter().map(|(name, v)| (name.as_str(), *v)));
    for (name, v) in given {
        let i = kind.gain_index(name).ok_or_else(|| reject(name))?;
        values[i] = v;
    }
    let mut settings = base.settings();
    if let Some(s) = a.switching {
        if !kind.has(Setting::Switching) {
            return Err(reject("switching"));
        }
        settings.switching = s;
    }
    if a.model_terms {
        if !kind.has(Setting::ModelTerms) {
            return Err(reject("model-terms"));
        }
        settings.model_terms = true;
    }
    Ok(Law::from_values(kind, values, settings))
}

/// The law `kind` at the payload (0 kg if none given) from `table`, or with the law's
/// starting gains without a table or a row for it.
pub(crate) fn default_law(
    table: Option<&DriveTable>,
    kind: LawKind,
    payload_kg: Option<f64>,
) -> Law {
    table
        .and_then(|t| t.law(kind, payload_kg.unwrap_or(0.0) as f32))
        .unwrap_or(Law::start(kind))
}

pub(crate) fn run_simulate(a: &SimulateArgs) -> anyhow::Result<()> {
    if a.motion.exact && !a.controller.has_observer() {
        bail!(
            "--exact plans on an observer law's reference beam; {} has none (use lqg or smc-modal)",
            a.controller.name()
        );
    }
    if a.true_state && !a.controller.has_observer() {
        bail!(
            "--true-state feeds an observer law's state; {} has no observer (use lqg or smc-modal)",
            a.controller.name()
        );
    }
    let beam = beam(&a.plant)?;
    let table = table_file::table_or_default(a.table.as_deref())?;
    let law = law(a, table)?;
    let payload_kg = a.plant.tip_mass.unwrap_or(0.0) as f32;
    let shaper = table.map_or(Shaper::NONE, |t| t.shaper(a.controller, payload_kg));
    let run_opts = a.run.options()?;
    let mut motion = a.motion.motion(None, shaper)?;
    // A table whose drive plans exact moves has its law plan them here too, as the drive
    // does (shortest moves to a target; others as before).
    motion.exact |= table.is_some_and(|t| t.drive.exact_moves && t.drive.law == a.controller);
    let opts = SimOptions {
        motion,
        fault: a.load.injection()?,
        // The drive's instruments: the table's (an observer law is designed on them), or
        // the encoder and gauge noise given.
        sensors: a.sensors.sensors(SensorConfig {
            encoder: table.map_or(run_opts.sensors.encoder, |t| t.drive.instruments.encoder),
            adc: table.map_or(run_opts.sensors.adc, |t| t.drive.instruments.adc),
            ..run_opts.sensors
        })?,
        true_state: a.true_state,
        ..run_opts
    };
    let run = with_modes!(a.plant.modes, simulate_n(&beam, law, &opts))?;
    let preset = &a.plant.preset_label();
    let title = format!(
        "{} slew, {} preset, {} modes",
        law.name(),
        preset,
        a.plant.modes
    );
    a.run.write(&run, &title)?;
    let settle = a.run.settle.spec()?;
    if a.run.json {
        println!(
            "{}",
            json!(run_json(&run, &law, preset, a.plant.modes, &settle)?)
        );
    } else {
        print_summary(&run, &law, preset, a.plant.modes, &settle);
    }
    Ok(())
}

pub(crate) fn simulate_n<const N: usize>(
    beam: &Beam,
    law: Law,
    opts: &SimOptions,
) -> anyhow::Result<SimResult> {
    let model = ModalModel::<N>::try_build(beam)?;
    simulate(&model, law, opts).map_err(anyhow::Error::from)
}
