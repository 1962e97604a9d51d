//! `beam telemetry`: a drive's defmt telemetry (a capture from the board, or the PIL drive's)
//! as the CSV `beam calibrate` reads.

use anyhow::{anyhow, bail, Context};
use beam_tools::io::files as io;
use beam_tools::link::telemetry::{self, Decoded};
use clap::Args;
use std::path::PathBuf;

#[derive(Args)]
pub struct TelemetryArgs {
    /// The captured telemetry: raw defmt bytes, or decoded text with --text.
    input: PathBuf,
    /// The firmware the capture came from (its defmt table decodes raw bytes).
    #[arg(long, value_name = "ELF", required_unless_present = "text")]
    elf: Option<PathBuf>,
    /// The input is text already decoded by `probe-rs run` or `defmt-print`.
    #[arg(long)]
    text: bool,
    /// Write every row, not just the first move's.
    #[arg(long)]
    all: bool,
    /// Tick period, s.
    #[arg(long, default_value_t = 1e-3)]
    ts: f64,
    /// The CSV to write.
    #[arg(long, value_name = "FILE")]
    out: PathBuf,
}

pub fn telemetry(a: &TelemetryArgs) -> anyhow::Result<()> {
    if !(a.ts.is_finite() && a.ts > 0.0 && a.ts <= 1.0) {
        bail!("--ts {} must be a period in (0, 1] s", a.ts);
    }
    let bytes = std::fs::read(&a.input).with_context(|| a.input.display().to_string())?;
    let decoded: Decoded = if a.text {
        let text = String::from_utf8(bytes).map_err(|_| {
            anyhow!(
                "{}: not UTF-8 text (drop --text for raw defmt)",
                a.input.display()
            )
        })?;
        telemetry::parse_text(&text).with_context(|| a.input.display().to_string())?
    } else {
        let elf_path = a
            .elf
            .as_ref()
            .context("--elf is needed to decode raw defmt")?;
        let elf = std::fs::read(elf_path).with_context(|| elf_path.display().to_string())?;
        telemetry::decode_defmt(&elf, &bytes).with_context(|| a.input.display().to_string())?
    };
    let rows = if a.all {
        &decoded.rows[..]
    } else {
        telemetry::first_move(&decoded.rows).ok_or_else(|| {
            anyhow!(
                "{}: no move in {} telemetry rows (--all writes them anyway)",
                a.input.display(),
                decoded.rows.len()
            )
        })?
    };
    if rows.is_empty() {
        bail!("{}: no telemetry rows", a.input.display());
    }
    let mut csv = vec![];
    telemetry::write_csv(rows, a.ts, &mut csv).with_context(|| a.input.display().to_string())?;
    io::write_atomically(&a.out, |w| w.write_all(&csv))
        .with_context(|| a.out.display().to_string())?;
    eprintln!(
        "{} rows written to {} ({} other messages, {} malformed frames skipped)",
        rows.len(),
        a.out.display(),
        decoded.other.len(),
        decoded.malformed
    );
    Ok(())
}
