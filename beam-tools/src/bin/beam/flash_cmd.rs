//! `beam flash`: flashes the firmware as it was last built (`cargo fw`) through a debug probe
//! with probe-rs, and runs it with its defmt telemetry printed. It never builds: what is
//! flashed is what `cargo fw` built, with the table it was built from, not a rebuild with
//! whatever `BEAM_GAIN_TABLE` says now.

use anyhow::{bail, Context};
use clap::Args;
use std::path::{Path, PathBuf};
use std::process::Command;

/// Where `cargo fw` puts the board's firmware.
const DEFAULT_ELF: &str = "target/thumbv7em-none-eabihf/release/firmware";

#[derive(Args)]
pub struct FlashArgs {
    /// The firmware to flash [default: target/thumbv7em-none-eabihf/release/firmware, as
    /// `cargo fw` built it].
    #[arg(long, value_name = "FILE")]
    elf: Option<PathBuf>,
    /// The target chip, as probe-rs names it.
    #[arg(long, default_value = "STM32F405RGTx")]
    chip: String,
    /// The probe-rs program.
    #[arg(long, value_name = "PROGRAM", default_value = "probe-rs")]
    probe_rs: String,
}

pub fn run(a: &FlashArgs) -> anyhow::Result<()> {
    let elf = a.elf.clone().unwrap_or_else(|| PathBuf::from(DEFAULT_ELF));
    check_elf(&elf)?;
    let mut command = Command::new(&a.probe_rs);
    command.args(["run", "--chip", &a.chip]).arg(&elf);
    eprintln!(
        "flashing {} (as built; run `cargo fw` first to change it)",
        elf.display()
    );
    let status = match command.status() {
        Ok(status) => status,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => bail!(
            "{}: not found: flashing needs probe-rs and a debug probe (`cargo install \
             probe-rs-tools --locked`, or --probe-rs PROGRAM)",
            a.probe_rs
        ),
        Err(e) => return Err(e).with_context(|| a.probe_rs.clone()),
    };
    if !status.success() {
        bail!("{} exited with {status}", a.probe_rs);
    }
    Ok(())
}

/// The firmware must exist and be an ARM ELF (not the host's stub binary).
fn check_elf(elf: &Path) -> anyhow::Result<()> {
    let bytes = std::fs::read(elf).map_err(|e| {
        anyhow::anyhow!(
            "{}: {e}: build the firmware first (`cargo fw`, or `BEAM_GAIN_TABLE=FILE cargo fw` for your table)",
            elf.display()
        )
    })?;
    // ELF magic, 32-bit, e_machine (bytes 18-19, little-endian) 40 = ARM.
    let arm = bytes.len() > 20 && bytes[..4] == *b"\x7fELF" && bytes[4] == 1 && bytes[18] == 40;
    if !arm {
        bail!(
            "{}: not firmware for the board (an ARM ELF): build it with `cargo fw`",
            elf.display()
        );
    }
    Ok(())
}
