//! The drive's defmt telemetry, decoded on the host into the CSV `beam calibrate` reads.
//!
//! Both firmware binaries log every tick as one defmt message in a fixed format,
//! `tlm {tick} {encoder_raw} {strain_code} {torque_nm} {theta_rad} {theta_ref_rad} {strain}
//! {mode} {faults}` (`beam_drive::drive::Telemetry::log`). This module decodes a raw defmt
//! stream with the `defmt-decoder` crate and the firmware ELF's format table (the bytes
//! `beam pil` collects from the emulated drive, or a raw RTT capture from the board), and also
//! accepts text that has already been decoded (`probe-rs run` or `defmt-print` output, one
//! message per line). Floats are printed by the decoder in shortest round-trip form, so the
//! values parsed back are the drive's f32s exactly.

use model_core::{FaultFlags, Mode};
use std::fmt::Write as _;

/// What is wrong with a telemetry stream or log.
#[derive(Debug, thiserror::Error)]
pub enum TelemetryError {
    /// A `tlm` message with fewer than nine fields.
    #[error("{0} fields after `tlm`, expected 9")]
    FieldCount(usize),
    /// A field that does not parse.
    #[error("field `{field}`: `{text}` is not a number")]
    NotANumber {
        /// The field's name.
        field: &'static str,
        /// What was there.
        text: String,
    },
    /// A mode number outside 0 to 3.
    #[error("field `mode`: `{0}` is not 0 to 3")]
    Mode(String),
    /// A malformed telemetry message in a decoded defmt stream.
    #[error("telemetry message `{text}`")]
    Message {
        /// The message.
        text: String,
        /// What is wrong with it.
        #[source]
        source: Box<TelemetryError>,
    },
    /// A malformed telemetry line in decoded text.
    #[error("line {line}")]
    Line {
        /// 1-based line number.
        line: usize,
        /// What is wrong with it.
        #[source]
        source: Box<TelemetryError>,
    },
    /// The ELF's defmt table could not be read.
    #[error("reading the firmware's defmt table: {0}")]
    Table(String),
    /// The ELF has no defmt table.
    #[error("the firmware has no defmt table (was it built with defmt?)")]
    NoTable,
    /// Nothing to write.
    #[error("no telemetry rows")]
    NoRows,
    /// A gap in the tick numbers.
    #[error("tick {tick} follows tick {previous}: samples were dropped")]
    Dropped {
        /// The tick found.
        tick: u32,
        /// The tick before it.
        previous: u32,
    },
    /// Writing the CSV failed.
    #[error(transparent)]
    Io(#[from] std::io::Error),
}

/// One tick as the drive logged it: the firmware's own telemetry record.
pub type Row = beam_drive::drive::Telemetry;

/// The controller mode of a logged or framed mode number (0 idle, 1 slewing, 2 holding,
/// 3 fault), as the firmware writes `mode as u8`.
pub fn mode_of(m: u8) -> Option<Mode> {
    Some(match m {
        0 => Mode::Idle,
        1 => Mode::Slewing,
        2 => Mode::Holding,
        3 => Mode::Fault,
        _ => return None,
    })
}

/// Parses one decoded message. `None` if it is not a telemetry message (other log lines are
/// skipped); an error if it is one but malformed.
pub fn parse_message(text: &str) -> Option<Result<Row, TelemetryError>> {
    let rest = text
        .split_whitespace()
        .skip_while(|w| *w != "tlm")
        .skip(1)
        .collect::<Vec<_>>();
    if !text.split_whitespace().any(|w| w == "tlm") {
        return None;
    }
    Some(parse_fields(&rest))
}

fn parse_fields(f: &[&str]) -> Result<Row, TelemetryError> {
    // Probe tools may append the log location after the message; the nine fields come first.
    if f.len() < 9 {
        return Err(TelemetryError::FieldCount(f.len()));
    }
    fn num<T: std::str::FromStr>(
        f: &[&str],
        i: usize,
        field: &'static str,
    ) -> Result<T, TelemetryError> {
        f[i].parse().map_err(|_| TelemetryError::NotANumber {
            field,
            text: f[i].to_string(),
        })
    }
    Ok(Row {
        tick: num(f, 0, "tick")?,
        encoder_raw: num(f, 1, "encoder_raw")?,
        strain_code: num(f, 2, "strain_code")?,
        torque_nm: num(f, 3, "torque_nm")?,
        theta_rad: num(f, 4, "theta_rad")?,
        theta_ref_rad: num(f, 5, "theta_ref_rad")?,
        strain: num(f, 6, "strain")?,
        mode: mode_of(num(f, 7, "mode")?).ok_or_else(|| TelemetryError::Mode(f[7].to_string()))?,
        faults: FaultFlags(num(f, 8, "faults")?),
    })
}

/// What decoding a stream found.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Decoded {
    /// Telemetry rows in stream order.
    pub rows: Vec<Row>,
    /// Other messages (errors, start-up lines), as text.
    pub other: Vec<String>,
    /// Frames the decoder could not read (skipped).
    pub malformed: usize,
}

/// Decodes a raw defmt byte stream with the format table of `elf`.
pub fn decode_defmt(elf: &[u8], stream: &[u8]) -> Result<Decoded, TelemetryError> {
    let table = defmt_decoder::Table::parse(elf)
        .map_err(|e| TelemetryError::Table(e.to_string()))?
        .ok_or(TelemetryError::NoTable)?;
    let mut decoder = table.new_stream_decoder();
    decoder.received(stream);
    let mut out = Decoded::default();
    loop {
        match decoder.decode() {
            Ok(frame) => {
                let text = frame.display_message().to_string();
                match parse_message(&text) {
                    Some(Ok(row)) => out.rows.push(row),
                    Some(Err(e)) => {
                        return Err(TelemetryError::Message {
                            text,
                            source: Box::new(e),
                        })
                    }
                    None => out.other.push(text),
                }
            }
            Err(defmt_decoder::DecodeError::UnexpectedEof) => break,
            Err(defmt_decoder::DecodeError::Malformed) => {
                out.malformed += 1;
                if !table.encoding().can_recover() {
                    break;
                }
            }
        }
    }
    Ok(out)
}

/// Parses already-decoded text, one message per line.
pub fn parse_text(text: &str) -> Result<Decoded, TelemetryError> {
    let mut out = Decoded::default();
    for (n, line) in text.lines().enumerate() {
        match parse_message(line) {
            Some(Ok(row)) => out.rows.push(row),
            Some(Err(e)) => {
                return Err(TelemetryError::Line {
                    line: n + 1,
                    source: Box::new(e),
                })
            }
            None if line.trim().is_empty() => {}
            None => out.other.push(line.to_string()),
        }
    }
    Ok(out)
}

/// The rows of the first move: from the first slewing tick to the end of the log or the
/// next idle tick. `None` if no move started.
pub fn first_move(rows: &[Row]) -> Option<&[Row]> {
    let start = rows.iter().position(|r| r.mode == Mode::Slewing)?;
    let len = rows[start..]
        .iter()
        .position(|r| r.mode == Mode::Idle)
        .unwrap_or(rows.len() - start);
    Some(&rows[start..start + len])
}

/// Writes `rows` as the CSV `beam calibrate` reads, with `t_s` counted from the first row's
/// tick at `ts_s` per tick. Ticks must increase by one: a gap (dropped samples) is an error,
/// since calibration needs uniform sampling.
pub fn write_csv(
    rows: &[Row],
    ts_s: f64,
    w: &mut dyn std::io::Write,
) -> Result<(), TelemetryError> {
    let first = rows.first().ok_or(TelemetryError::NoRows)?.tick;
    let mut s = String::from(
        "t_s,tick,encoder_raw,strain_code,torque_nm,theta_rad,theta_ref_rad,root_strain,mode,faults\n",
    );
    for (i, r) in rows.iter().enumerate() {
        let expected = first.wrapping_add(i as u32);
        if r.tick != expected {
            return Err(TelemetryError::Dropped {
                tick: r.tick,
                previous: rows[i - 1].tick,
            });
        }
        let _ = writeln!(
            s,
            "{},{},{},{},{},{},{},{},{},{}",
            beam_sim::decimal::tick_time(i, ts_s),
            r.tick,
            r.encoder_raw,
            r.strain_code,
            r.torque_nm,
            r.theta_rad,
            r.theta_ref_rad,
            r.strain,
            r.mode as u8,
            r.faults.0
        );
    }
    Ok(w.write_all(s.as_bytes())?)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn messages_parse_exactly_and_other_lines_are_kept_apart() {
        let text = "INFO drive up\n\
                    [INFO ] tlm 7 65535 -1234 1.25 -1.5707964 -1.5707964 1e-6 1 0 (firmware src/drive.rs:60)\n\
                    \n";
        let d = parse_text(text).unwrap();
        assert_eq!(d.other, ["INFO drive up"]);
        assert_eq!(
            d.rows,
            [Row {
                tick: 7,
                encoder_raw: 65535,
                strain_code: -1234,
                torque_nm: 1.25,
                theta_rad: -std::f32::consts::FRAC_PI_2,
                theta_ref_rad: -std::f32::consts::FRAC_PI_2,
                strain: 1e-6,
                mode: Mode::Slewing,
                faults: FaultFlags(0),
            }]
            .to_vec()
        );
    }

    #[test]
    fn malformed_telemetry_is_an_error_naming_the_field() {
        let e = parse_text("tlm 1 2 3 x 5 6 7 8 9").unwrap_err();
        let TelemetryError::Line { line: 1, source } = e else {
            panic!("{e:?}")
        };
        assert!(
            matches!(
                *source,
                TelemetryError::NotANumber {
                    field: "torque_nm",
                    ..
                }
            ),
            "{source:?}"
        );
        assert!(matches!(
            parse_text("tlm 1 2 3").unwrap_err(),
            TelemetryError::Line { source, .. } if matches!(*source, TelemetryError::FieldCount(3))
        ));
    }

    #[test]
    fn a_gap_in_the_ticks_is_refused() {
        let row = |tick| Row {
            tick,
            encoder_raw: 0,
            strain_code: 0,
            torque_nm: 0.0,
            theta_rad: 0.0,
            theta_ref_rad: 0.0,
            strain: 0.0,
            mode: Mode::Slewing,
            faults: FaultFlags(0),
        };
        let mut out = vec![];
        assert!(matches!(
            write_csv(&[row(5), row(6), row(8)], 1e-3, &mut out),
            Err(TelemetryError::Dropped {
                tick: 8,
                previous: 6
            })
        ));
        let mut out = vec![];
        write_csv(&[row(5), row(6)], 1e-3, &mut out).unwrap();
        let text = String::from_utf8(out).unwrap();
        assert!(text.lines().nth(2).unwrap().starts_with("0.001,6,"));
    }
}
