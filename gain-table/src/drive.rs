//! The table's `[drive]`: what the drive built from the table runs and how it reads its
//! instruments. Optional; each key defaults to the shipped drive's.
//!
//! ```toml
//! [drive]
//! law = "smc"                     # the law the drive runs (the table must have its rows)
//! payload_kg = 0.0                # the payload it starts with (within the plant's range)
//! encoder_counts_per_rev = 16384  # after quadrature decoding
//! encoder_counter_bits = 16       # the hardware counter's width
//! adc_bits = 24                   # the strain converter's resolution
//! strain_full_scale = 0.005       # strain at the converter's positive full scale
//! torque_full_scale_nm = 10.0     # torque at 100 % PWM duty
//! encoder_reversed = false        # the counter counts down as the hub turns positive
//! strain_reversed = false         # positive strain reads as negative codes
//! torque_reversed = false         # positive torque needs the direction pin low
//! exact_moves = false             # shortest moves exact on the law's reference beam
//! ```
//!
//! The conventions: positive hub angle and torque are the same way round (counter-clockwise
//! seen from above the hub, by the shipped drive's wiring), and positive strain is the
//! root's surface stretched when the hub accelerates positive. The three `*_reversed` keys
//! say where a rig's wiring differs, so it need not be rewired; they are applied as signs of
//! the scales when the drive is built, at no cost in the tick.

use crate::Row;
use beam_kinds::LawKind;
use serde::{Deserialize, Serialize};

/// The `[drive]` table.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct DriveSpec {
    /// The law the drive runs.
    pub law: LawKind,
    /// The payload it starts with, kg.
    pub payload_kg: f64,
    /// Encoder counts per revolution after quadrature decoding.
    pub encoder_counts_per_rev: u32,
    /// Width of the hardware counter, bits (2 to 32).
    pub encoder_counter_bits: u8,
    /// The strain converter's resolution, bits (2 to 32).
    pub adc_bits: u8,
    /// Strain at the converter's positive full scale (the gauge factor, the bridge and the
    /// amplifier's gain together).
    pub strain_full_scale: f64,
    /// Torque at 100 % PWM duty, N m (the amplifier's current scale times the motor's torque
    /// constant).
    pub torque_full_scale_nm: f64,
    /// The encoder counts down as the hub turns positive.
    #[serde(skip_serializing_if = "is_false")]
    pub encoder_reversed: bool,
    /// Positive strain reads as negative converter codes.
    #[serde(skip_serializing_if = "is_false")]
    pub strain_reversed: bool,
    /// Positive torque needs the amplifier's direction pin low.
    #[serde(skip_serializing_if = "is_false")]
    pub torque_reversed: bool,
    /// An observer law's shortest moves to a target planned to leave its reference beam at
    /// rest (model-core's `planner::exact`): for a table made on the drive's own beam (`beam
    /// calibrate`, then a table on the plant found). The board needs the firmware's `exact`
    /// feature for it (`cargo fw --features exact`).
    #[serde(skip_serializing_if = "is_false")]
    pub exact_moves: bool,
}

fn is_false(b: &bool) -> bool {
    !*b
}

/// The reference drive: the paper's law and the instruments model-core starts from
/// (`Instruments::DEFAULT`), so a table without `[drive]` and a loop built on the defaults
/// read the beam alike.
impl Default for DriveSpec {
    fn default() -> Self {
        let model_core::Instruments { encoder, adc } = model_core::Instruments::DEFAULT;
        Self {
            law: LawKind::DEFAULT_DRIVE,
            payload_kg: 0.0,
            encoder_counts_per_rev: encoder.counts_per_rev,
            encoder_counter_bits: encoder.counter_bits,
            adc_bits: adc.bits,
            strain_full_scale: adc.full_scale_strain,
            torque_full_scale_nm: model_core::DRIVE_TORQUE_LIMIT_NM as f64,
            encoder_reversed: encoder.reversed,
            strain_reversed: adc.reversed,
            torque_reversed: false,
            exact_moves: false,
        }
    }
}

/// The fastest hub speed the drive takes as physically possible, rad/s: a bigger change of
/// count in a tick is an encoder fault (`ControllerSettings::max_speed_rad_s`), and the
/// drive is refused an encoder whose counter cannot keep count at it.
pub const ENCODER_TOP_RAD_S: f64 =
    model_core::ControllerSettings::new(model_core::Instruments::DEFAULT).max_speed_rad_s as f64;

/// Whether `encoder` read every tick keeps count of a hub turning at [`ENCODER_TOP_RAD_S`]
/// (a counter that moves half its range in a tick is read as turning the other way), as the
/// drive checks it when it is built. `Err` says why not, and what to change.
pub fn encoder_reads_the_hub(encoder: &model_core::EncoderSpec) -> Result<(), String> {
    let top = encoder.max_rate_rad_s(f64::from(model_core::DEFAULT_TS_S));
    if top >= ENCODER_TOP_RAD_S {
        return Ok(());
    }
    Err(format!(
        "a {}-bit counter at {} counts per revolution keeps count only up to {top:.1} rad/s \
         at the 1 kHz tick, under the {ENCODER_TOP_RAD_S} rad/s the drive takes as the \
         fastest a hub can turn: widen the counter (encoder_counter_bits) or use fewer counts",
        encoder.counter_bits, encoder.counts_per_rev
    ))
}

/// A `[drive]` error: the field and why.
pub(crate) type DriveError = (&'static str, String);

impl DriveSpec {
    pub(crate) fn from_value(v: &toml::Value) -> Result<Self, DriveError> {
        v.clone()
            .try_into()
            .map_err(|e: toml::de::Error| ("drive", format!("[drive]: {}", e.message().trim())))
    }

    /// Checks the values, and that the table can serve them: rows of the law (PD has its
    /// baseline without), a payload within the rows' range, and an amplifier that reaches
    /// the plant's torque limit.
    pub(crate) fn check(&self, rows: &[Row], torque_limit_nm: f64) -> Result<(), DriveError> {
        let why = |field, m: String| Err((field, format!("[drive]: {m}")));
        if self.law != LawKind::Pd && !rows.iter().any(|r| r.gains.kind() == self.law) {
            return why(
                "law",
                format!("{}: the table has no {} row", self.law, self.law),
            );
        }
        let heaviest = rows
            .iter()
            .map(|r| r.payload_kg as f32 as f64)
            .fold(0.0, f64::max);
        if !(self.payload_kg >= 0.0 && self.payload_kg <= heaviest) {
            return why(
                "payload_kg",
                format!(
                    "{} kg is outside the rows' payloads, 0 to {heaviest} kg",
                    self.payload_kg
                ),
            );
        }
        if self.exact_moves && !self.law.has_observer() {
            return why(
                "exact_moves",
                format!(
                    "{}: exact moves are planned on an observer law's reference beam (lqg, smc-modal)",
                    self.law
                ),
            );
        }
        if self.encoder_counts_per_rev == 0 {
            return why("encoder_counts_per_rev", "must be > 0".into());
        }
        for (field, bits) in [
            ("encoder_counter_bits", self.encoder_counter_bits),
            ("adc_bits", self.adc_bits),
        ] {
            if !(2..=32).contains(&bits) {
                return why(field, format!("{bits} is not 2 to 32"));
            }
        }
        if let Err(m) = encoder_reads_the_hub(&self.instruments().encoder) {
            return why("encoder_counter_bits", m);
        }
        if !(self.strain_full_scale.is_finite() && self.strain_full_scale > 0.0) {
            return why(
                "strain_full_scale",
                format!("{} must be > 0", self.strain_full_scale),
            );
        }
        if !(self.torque_full_scale_nm.is_finite() && self.torque_full_scale_nm >= torque_limit_nm)
        {
            return why(
                "torque_full_scale_nm",
                format!(
                    "{} N m: the amplifier must reach the plant's torque limit, {torque_limit_nm} N m",
                    self.torque_full_scale_nm
                ),
            );
        }
        Ok(())
    }

    /// The `[drive]` table's text.
    pub fn render(&self) -> String {
        format!(
            "[drive]\n{}",
            toml::to_string(self).unwrap_or_else(|e| format!("# {e}\n"))
        )
    }
}

/// Rust source for `DRIVE: DriveConfig`, in the drive's `f32`.
pub(crate) fn generate(d: &model_core::DriveConfig) -> String {
    let (e, a) = (d.instruments.encoder, d.instruments.adc);
    format!(
        "/// The drive the table configures (its `[drive]`).\n\
         pub const DRIVE: ::model_core::DriveConfig = ::model_core::DriveConfig {{\n    \
         law: ::model_core::LawKind::{:?},\n    payload_kg: {:?},\n    \
         instruments: ::model_core::Instruments {{\n        \
         encoder: ::model_core::EncoderSpec {{ counts_per_rev: {}, counter_bits: {}, reversed: {} }},\n        \
         adc: ::model_core::AdcSpec {{ bits: {}, full_scale_strain: {:?}, reversed: {} }},\n    }},\n    \
         torque_full_scale_nm: {:?},\n    torque_reversed: {},\n    exact_moves: {},\n}};\n",
        d.law,
        d.payload_kg,
        e.counts_per_rev,
        e.counter_bits,
        e.reversed,
        a.bits,
        a.full_scale_strain,
        a.reversed,
        d.torque_full_scale_nm,
        d.torque_reversed,
        d.exact_moves
    )
}
