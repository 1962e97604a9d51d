//! A gain table read at run time (as `beam optimize --table` writes it), in the form
//! model-core schedules from, so a candidate table can be simulated and swept before it is
//! compiled into the firmware.

use gain_table::Row;
use model_core::gains::GainRow;
use model_core::law::MAX_GAINS;
use model_core::{Law, Shaper};

/// The rows of `rows` as the drive would run them: gains rounded to f32, as the build does.
/// Rows keep their order (the table's parser has already checked that each controller's rows
/// are sorted by payload, which `model_core::gains::schedule` relies on).
pub fn gain_rows(rows: &[Row]) -> Vec<GainRow> {
    rows.iter().map(gain_row).collect()
}

fn gain_row(r: &Row) -> GainRow {
    let mut values = [0.0f32; MAX_GAINS];
    for (v, &g) in values.iter_mut().zip(r.gains.values()) {
        *v = g as f32;
    }
    let law = Law::from_values(r.gains.kind(), values, r.gains.settings());
    GainRow {
        payload_kg: r.payload_kg as f32,
        law,
        shaper: Shaper {
            kind: r.shaper.kind,
            freq_hz: r.shaper.hz as f32,
            damping: r.shaper.damping as f32,
            tolerance: r.shaper.tolerance as f32,
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_shipped_table_read_at_run_time_equals_the_compiled_one() {
        let text = include_str!("../../../gains.toml");
        let rows = gain_table::parse(text, "gains.toml").unwrap();
        assert_eq!(gain_rows(&rows.rows), model_core::gains::GAIN_TABLE);
    }
}
