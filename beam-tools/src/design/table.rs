//! A gain table read at run time (as `beam optimize --table` writes it), in the form
//! model-core schedules from, so a candidate table can be simulated and swept before it is
//! compiled into the firmware.

use gain_table::{Gains, Row};
use model_core::gains::GainRow;
use model_core::{Law, LqgGains, PdFfGains, PdGains, Shaper, SmcGains, SmcIGains, StrainSmcGains};

/// The rows of `rows` as the drive would run them: gains rounded to f32, as the build does.
/// Rows keep their order (the table's parser has already checked that each controller's rows
/// are sorted by payload, which `model_core::gains::schedule` relies on).
pub fn gain_rows(rows: &[Row]) -> Vec<GainRow> {
    rows.iter().map(gain_row).collect()
}

fn gain_row(r: &Row) -> GainRow {
    let smc = |w: f64, a: f64, beta: f64, switching| SmcGains {
        w: w as f32,
        a: a as f32,
        beta: beta as f32,
        switching,
    };
    let law = match &r.gains {
        Gains::Pd(g) => Law::Pd(PdGains {
            kp: g.kp as f32,
            kd: g.kd as f32,
        }),
        Gains::Smc(g) => Law::Smc(smc(g.w, g.a, g.beta, g.switching)),
        Gains::SmcStrain(g) => Law::SmcStrain(StrainSmcGains {
            smc: smc(g.w, g.a, g.beta, g.switching),
            c: g.c as f32,
            model_terms: g.model_terms,
        }),
        Gains::PdFf(g) => Law::PdFf(PdFfGains {
            kp: g.kp as f32,
            kd: g.kd as f32,
        }),
        Gains::SmcI(g) => Law::SmcI(SmcIGains {
            w: g.w as f32,
            wi: g.wi as f32,
            c: g.c as f32,
            a: g.a as f32,
            beta: g.beta as f32,
            switching: g.switching,
        }),
        Gains::Lqg(g) => Law::Lqg(LqgGains {
            kp: g.kp as f32,
            kd: g.kd as f32,
            ki: g.ki as f32,
            kq: g.kq as f32,
            sigma: g.sigma as f32,
        }),
    };
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
