//! `beam pil`: the paper's slew with the PIL firmware under QEMU as the drive, compared bit
//! for bit with the host's build of the same drive.

use crate::{named, PlantArgs, RunArgs};
use anyhow::Context;
use beam_sim::plant::Plant;
use beam_sim::sim::SimOptions;
use beam_tools::io::files as io;
use beam_tools::link::pil_host::{
    build_plugin, paths, run_pil, InsnProfile, PilConfig, PilOutcome,
};
use beam_tools::link::telemetry;
use clap::Args;
use model_core::{Beam, LawKind, ModalModel};
use serde_json::json;
use std::path::PathBuf;

#[derive(Args)]
pub struct PilArgs {
    /// The simulated plant (the drive's own model is always aluminium, 3 modes; --payload
    /// goes to both).
    #[command(flatten)]
    plant: PlantArgs,
    /// The gain table the PIL firmware was built from, which the host builds the same drive
    /// from to compare [default: $BEAM_GAIN_TABLE, as `cargo pil-fw` reads it, else
    /// the repository's gains.toml].
    #[arg(long, value_name = "FILE")]
    table: Option<PathBuf>,
    /// Control law the drive runs (gains from the gain table; PD baseline gains).
    #[arg(long, value_parser = named::<LawKind>(), default_value = "smc")]
    controller: LawKind,
    #[command(flatten)]
    run: RunArgs,
    /// The PIL firmware [default: target/thumbv7em-none-eabihf/release/pil, built by `cargo pil-fw`; for lqg and smc-modal, release/pil-observer, built by `cargo pil-fw-observer`].
    #[arg(long, value_name = "ELF")]
    elf: Option<PathBuf>,
    /// The QEMU binary.
    #[arg(long, default_value = "qemu-system-arm")]
    qemu: String,
    /// Seconds before QEMU is killed.
    #[arg(long, default_value_t = 120, value_parser = clap::value_parser!(u32).range(1..=3600))]
    timeout: u32,
    /// The instruction-count plugin [default: built with gcc from beam-tools/qemu-plugin].
    #[arg(long, value_name = "SO")]
    insn_plugin: Option<PathBuf>,
    /// Do not count instructions.
    #[arg(long, conflicts_with_all = ["insn_plugin", "insn_profile"])]
    no_insn_count: bool,
    /// Also profile the tick: write the plugin's per-address counts to FILE, for
    /// `beam-tools/qemu-plugin/profile.py ELF FILE` (several times slower).
    #[arg(long, value_name = "FILE")]
    insn_profile: Option<PathBuf>,
    /// With --insn-profile: count the worst tick alone (the first with the most
    /// instructions), not every tick summed.
    #[arg(long, requires = "insn_profile")]
    worst_tick: bool,
    /// Write the drive's telemetry for the move as CSV (the `beam calibrate` format).
    #[arg(long, value_name = "FILE")]
    telemetry: Option<PathBuf>,
}

pub fn run(a: &PilArgs) -> anyhow::Result<()> {
    let opts = a.run.options()?;
    let beam = crate::beam(&a.plant)?;
    let payload_kg = beam.params().tip_mass_kg as f32;
    let plugin = match (&a.insn_plugin, a.no_insn_count) {
        (_, true) => None,
        (Some(p), false) => Some(p.clone()),
        (None, false) => Some(build_plugin(
            &paths::insn_plugin_src(),
            &paths::plugin_dir(),
        )?),
    };
    let cfg = PilConfig {
        elf: a
            .elf
            .clone()
            .unwrap_or_else(|| paths::pil_elf(a.controller)),
        qemu: a.qemu.clone(),
        plugin,
        profile: match (&a.insn_profile, a.worst_tick) {
            (None, _) => InsnProfile::Off,
            (Some(_), false) => InsnProfile::AllTicks,
            (Some(_), true) => InsnProfile::WorstTick,
        },
        timeout_s: a.timeout,
        controller: a.controller,
        payload_kg,
        table: beam_tools::io::table_file::required_table(a.table.as_deref())?,
    };
    let law = cfg
        .table
        .law(cfg.controller, payload_kg)
        .with_context(|| format!("the gain table has no `{}` rows", cfg.controller))?;
    let out = with_modes!(a.plant.modes, pil_n(&beam, &cfg, &opts))?;
    if let Some(path) = &a.insn_profile {
        io::write_atomically(path, |w| w.write_all(out.insn_log.as_bytes()))
            .with_context(|| path.display().to_string())?;
    }
    if let Some(path) = &a.telemetry {
        let rows = telemetry::first_move(&out.telemetry.rows)
            .context("the drive's telemetry shows no move")?;
        io::write_atomically(path, |w| {
            telemetry::write_csv(rows, 1e-3, w).map_err(std::io::Error::other)
        })
        .with_context(|| path.display().to_string())?;
    }
    let preset = &a.plant.preset_label();
    let title = format!(
        "{} slew (PIL), {} preset, {} modes",
        law.name(),
        preset,
        a.plant.modes
    );
    a.run.write(&out.run, &title)?;
    let insns = out.insns;
    if a.run.json {
        let mut o = crate::run_json(&out.run, &law, preset, a.plant.modes, &a.run.settle.spec()?)?;
        o.insert("pil_ticks".into(), json!(out.ticks));
        o.insert("pil_max_torque_diff".into(), json!(out.max_torque_diff));
        o.insert("pil_max_ulps".into(), json!(out.max_ulps));
        o.insert("pil_identical".into(), json!(out.identical));
        o.insert("insns_min".into(), json!(insns.map(|i| i.min)));
        o.insert("insns_mean".into(), json!(insns.map(|i| i.mean)));
        o.insert("insns_max".into(), json!(insns.map(|i| i.max)));
        println!("{}", json!(o));
    } else {
        crate::print_summary(&out.run, &law, preset, a.plant.modes, &a.run.settle.spec()?);
        println!(
            "  PIL: {} ticks on the emulated STM32F405; torques {} the host build's{}",
            out.ticks,
            if out.identical {
                "bit-identical to"
            } else {
                "differ from"
            },
            if out.identical {
                String::new()
            } else {
                format!(
                    " (max {:.3e} N m, {} ulps)",
                    out.max_torque_diff, out.max_ulps
                )
            }
        );
        if let Some(i) = insns {
            println!(
                "  instructions per tick: min {}, mean {:.1}, max {}",
                i.min, i.mean, i.max
            );
        }
    }
    Ok(())
}

fn pil_n<const N: usize>(
    beam: &Beam,
    cfg: &PilConfig,
    opts: &SimOptions,
) -> anyhow::Result<PilOutcome> {
    let model = ModalModel::<N>::try_build(beam)?;
    Ok(run_pil(Plant::new(model), cfg, opts)?)
}
