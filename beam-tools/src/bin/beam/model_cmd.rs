//! `beam model`: a plant's modal model (matrices, clamped and pinned frequencies), and its
//! parameters written as a file to start a rig's from.

use crate::{beam, PlantArgs};
use anyhow::Context;
use beam_tools::io::files as io;
use clap::Args;
use model_core::{Beam, ModalModel};
use serde_json::json;
use std::path::PathBuf;

#[derive(Args)]
pub(crate) struct ModelArgs {
    #[command(flatten)]
    plant: PlantArgs,
    /// Print one JSON object.
    #[arg(long)]
    json: bool,
    /// Also write the plant's parameters to FILE, as `calibrate --out` does: a starting
    /// point to edit for your own rig, or a `--params` file for the other commands.
    #[arg(long, value_name = "FILE")]
    out: Option<PathBuf>,
}

pub(crate) fn run_model(a: &ModelArgs) -> anyhow::Result<()> {
    let beam = beam(&a.plant)?;
    with_modes!(a.plant.modes, print_model(&beam, a))?;
    if let Some(path) = &a.out {
        let comment = format!(
            "the {} plant, written by beam model",
            a.plant.preset_label()
        );
        let text = beam_tools::io::params_file::render(beam.params(), &comment);
        io::write_atomically(path, |w| w.write_all(text.as_bytes()))
            .with_context(|| path.display().to_string())?;
        if !a.json {
            println!("parameters written to {}", path.display());
        }
    }
    Ok(())
}

pub(crate) fn print_model<const N: usize>(beam: &Beam, a: &ModelArgs) -> anyhow::Result<()> {
    let m = ModalModel::<N>::try_build(beam)?;
    let p = beam.params();
    let preset = &a.plant.preset_label();
    if a.json {
        let rows = |x: &[[f64; N]; N]| x.iter().map(|r| r.to_vec()).collect::<Vec<_>>();
        let v = json!({
            "preset": preset, "modes": N, "ei": p.ei_nm2, "rho": m.rho_kg_m, "tip_mass": p.tip_mass_kg,
            "mtt": m.mtt, "jeff": m.jeff, "h": m.h.to_vec(), "mqq": rows(&m.mqq), "kqq": rows(&m.kqq),
            "g": rows(&m.g), "s": rows(&m.s), "clamped_hz": m.clamped_hz.to_vec(), "pinned_hz": m.pinned_hz.to_vec(),
            "root_strain_coef": m.root_strain_coef.to_vec(), "tip_coef": m.tip_coef.to_vec(),
        });
        println!("{v}");
        return Ok(());
    }
    println!("preset {preset}, {N} mode(s)");
    println!(
        "  EI {:.4} N m^2, rho {:.4} kg/m, tip mass {} kg",
        p.ei_nm2, m.rho_kg_m, p.tip_mass_kg
    );
    println!("  Mtt {:.5e} kg m^2, Jeff {:.5e} kg m^2", m.mtt, m.jeff);
    println!("  h   {:?}", m.h);
    println!("  Mqq {:?}", m.mqq);
    println!("  Kqq {:?}", m.kqq);
    println!("  G   {:?}", m.g);
    println!("  clamped Hz {:?}", m.clamped_hz);
    println!("  pinned  Hz {:?}", m.pinned_hz);
    Ok(())
}
