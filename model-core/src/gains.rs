//! The gain table compiled in at build time, and gain scheduling over the payload.
//!
//! `build.rs` turns the checked-in `gains.toml` into [`GAIN_TABLE`]; [`schedule`] picks the
//! gains for a configured payload, interpolating linearly between the neighbouring rows of the
//! chosen controller and holding the end rows outside their range. Scheduling happens when the
//! drive is configured, not in the tick: the result is validated by `ControlLaw::try_build`
//! and swapped in whole.

use crate::law::{Law, LawKind, LawPlant, LqgGains, ASSUMED_STRAIN_NOISE, LQG_MODES};
use crate::modal::ModalModel;
use crate::plant::PlantPoint;
use crate::shaper::Shaper;
use beam_model::lqg::{self, LqgDesign, LqgError, LqgWeights, SensorNoise};

/// One row of the table: the gains for one controller at one payload.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GainRow {
    /// Payload (tip mass), kg.
    pub payload_kg: f32,
    /// The controller and its gains.
    pub law: Law,
    /// The input shaper designed with them.
    pub shaper: Shaper,
}

/// The drive a gain table configures (its `[drive]`): the law it runs, the payload it starts
/// with, and how it reads its instruments. [`DRIVE`] is the compiled table's;
/// [`ControllerSettings::default`](crate::ControllerSettings) reads its instruments.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DriveConfig {
    /// The law the drive runs.
    pub law: LawKind,
    /// The payload it starts with, kg.
    pub payload_kg: f32,
    /// The hub encoder.
    pub encoder: crate::measure::EncoderSpec,
    /// The root strain converter.
    pub adc: crate::measure::AdcSpec,
    /// Torque at 100 % PWM duty, N m (at least the plant's torque limit, so saturation never
    /// clips twice).
    pub torque_full_scale_nm: f32,
    /// Positive torque needs the amplifier's direction pin low.
    pub torque_reversed: bool,
}

include!(concat!(env!("OUT_DIR"), "/gain_table.rs"));

/// The LQG law is designed on a whole modal model, with the compiled [`DRIVE`]'s instruments
/// as the observer's sensor noise: the encoder's quantisation (step / sqrt(12)) and the root
/// gauge's, at least [`ASSUMED_STRAIN_NOISE`].
impl<const N: usize> LawPlant for &ModalModel<N> {
    fn point(&self) -> PlantPoint {
        PlantPoint::of(self)
    }

    fn lqg(&self, g: &LqgGains, ts_s: f64) -> Option<Result<LqgDesign, LqgError>> {
        if !cfg!(feature = "observer") {
            return None;
        }
        let weights = LqgWeights {
            kp: g.kp as f64,
            kd: g.kd as f64,
            ki: g.ki as f64,
            kq: g.kq as f64,
            sigma_nm: g.sigma as f64,
        };
        let quantum = |step: f64| step / libm::sqrt(12.0);
        let noise = SensorNoise {
            theta_rad: quantum(DRIVE.encoder.rad_per_count()),
            strain: quantum(DRIVE.adc.strain_per_code()).max(ASSUMED_STRAIN_NOISE),
        };
        // On the first LQG_MODES modes: a controller that also observes the higher modes
        // tracks them on the model's frequencies, and a beam a few percent off those turns
        // them unstable (spillover; with 1 % damping there is no margin to spare). Left out,
        // they see a gain that has rolled off by their frequencies. A model with fewer modes
        // is designed on as it is.
        Some(match lqg::leading_modes::<N, LQG_MODES>(self) {
            Some(leading) => lqg::design(&leading, &weights, &noise, ts_s),
            None => lqg::design(*self, &weights, &noise, ts_s),
        })
    }
}

/// An observer law's design made on the host at one row of the table (for a drive, which
/// cannot solve the design's Riccati equations): the law, the row's payload and the design
/// for the row's gains.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DesignRow {
    /// The law (lqg or smc-modal).
    pub kind: LawKind,
    /// The row's payload, kg.
    pub payload_kg: f32,
    /// The design for the row's gains on the plant carrying that payload.
    pub design: LqgDesign,
}

/// The design of law `kind` at `payload_kg` from `rows`, mixed between the neighbouring
/// rows as [`schedule`] mixes their gains (the same fraction), the end rows held outside
/// their range; `None` without a row of that law.
pub fn schedule_design(rows: &[DesignRow], kind: LawKind, payload_kg: f32) -> Option<LqgDesign> {
    let mut rows = rows.iter().filter(|r| r.kind == kind);
    let first = rows.next()?;
    if !(payload_kg > first.payload_kg) {
        return Some(first.design);
    }
    let mut below = first;
    for above in rows {
        if payload_kg == above.payload_kg {
            // At a row, its design exactly (a mix with weight 1 can round apart from it).
            return Some(above.design);
        }
        if payload_kg < above.payload_kg {
            let f = (payload_kg - below.payload_kg) / (above.payload_kg - below.payload_kg);
            return Some(below.design.mix(&above.design, f));
        }
        below = above;
    }
    Some(below.design)
}

/// A drive's compiled plant at its payload with, for an observer law, the design made on the
/// host ([`schedule_design`]): what a drive builds an lqg or smc-modal law on. The design
/// must be the one for the gains the law is built with (the table's, scheduled on the same
/// payload); it is not checked against them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DesignedPlant {
    /// The plant at the payload.
    pub point: PlantPoint,
    /// The observer law's design, if any.
    pub design: Option<LqgDesign>,
}

impl LawPlant for DesignedPlant {
    fn point(&self) -> PlantPoint {
        self.point
    }

    fn lqg(&self, _: &LqgGains, _: f64) -> Option<Result<LqgDesign, LqgError>> {
        self.design.map(Ok)
    }
}

/// The gains for law `kind` at `payload_kg`, from `table`; `None` if the table has no row for
/// that law. A NaN payload takes the lightest row.
pub fn schedule(table: &[GainRow], kind: LawKind, payload_kg: f32) -> Option<Law> {
    let mut rows = table.iter().filter(|r| r.law.kind() == kind);
    let first = rows.next()?;
    if !(payload_kg > first.payload_kg) {
        return Some(first.law);
    }
    let mut below = first;
    for above in rows {
        if payload_kg <= above.payload_kg {
            let f = (payload_kg - below.payload_kg) / (above.payload_kg - below.payload_kg);
            return Some(lerp(&below.law, &above.law, f));
        }
        below = above;
    }
    Some(below.law)
}

/// The law `kind` for `payload_kg` from `table` ([`schedule`]), or for PD without rows the
/// baseline gains. `None` if the table has no row for any other law.
pub fn scheduled_law(table: &[GainRow], kind: LawKind, payload_kg: f32) -> Option<Law> {
    schedule(table, kind, payload_kg).or((kind == LawKind::Pd).then_some(Law::start(LawKind::Pd)))
}

/// The input shaper of law `kind` at `payload_kg`: its rows' shaper, frequency and damping
/// interpolated like the gains. No shaping without rows.
pub fn schedule_shaper(table: &[GainRow], kind: LawKind, payload_kg: f32) -> Shaper {
    let mut rows = table.iter().filter(|r| r.law.kind() == kind);
    let Some(first) = rows.next() else {
        return Shaper::NONE;
    };
    if !(payload_kg > first.payload_kg) {
        return first.shaper;
    }
    let mut below = first;
    for above in rows {
        if payload_kg <= above.payload_kg {
            let f = (payload_kg - below.payload_kg) / (above.payload_kg - below.payload_kg);
            let mix = |a: f32, b: f32| a + (b - a) * f;
            return Shaper {
                freq_hz: mix(below.shaper.freq_hz, above.shaper.freq_hz),
                damping: mix(below.shaper.damping, above.shaper.damping),
                ..below.shaper
            };
        }
        below = above;
    }
    below.shaper
}

/// The gains between two rows of one law, each by the same linear mix; the settings are
/// the lower row's (the table's build makes a law's rows agree on them). Past the law's
/// gains both rows hold zero, and so does the mix.
fn lerp(lo: &Law, hi: &Law, f: f32) -> Law {
    let (a, b) = (lo.values(), hi.values());
    lo.with_values(core::array::from_fn(|i| a[i] + (b[i] - a[i]) * f))
}

#[cfg(test)]
mod tests {
    use super::*;

    use crate::law::{PdGains, SmcGains, Switching};

    const G: SmcGains = SmcGains {
        w: 10.0,
        a: 100.0,
        beta: 0.1,
        switching: Switching::Tanh,
    };
    const TABLE: [GainRow; 3] = [
        GainRow {
            payload_kg: 0.0,
            law: Law::Smc(G),
            shaper: Shaper::NONE,
        },
        GainRow {
            payload_kg: 0.05,
            law: Law::Smc(SmcGains {
                w: 20.0,
                a: 300.0,
                ..G
            }),
            shaper: Shaper::NONE,
        },
        GainRow {
            payload_kg: 0.01,
            law: Law::Pd(PdGains { kp: 20.0, kd: 1.0 }),
            shaper: Shaper::NONE,
        },
    ];

    #[test]
    fn interpolates_between_rows_and_holds_the_ends() {
        let mid = schedule(&TABLE, LawKind::Smc, 0.025).unwrap();
        assert_eq!(
            mid,
            Law::Smc(SmcGains {
                w: 15.0,
                a: 200.0,
                ..G
            })
        );
        assert_eq!(schedule(&TABLE, LawKind::Smc, -1.0).unwrap(), TABLE[0].law);
        assert_eq!(schedule(&TABLE, LawKind::Smc, 9.0).unwrap(), TABLE[1].law);
        assert_eq!(
            schedule(&TABLE, LawKind::Smc, f32::NAN).unwrap(),
            TABLE[0].law
        );
        assert_eq!(schedule(&TABLE, LawKind::Pd, 0.3).unwrap(), TABLE[2].law);
        assert_eq!(schedule(&TABLE, LawKind::SmcStrain, 0.0), None);
    }

    #[test]
    fn designs_are_mixed_between_points_exact_at_them_and_held_past_the_ends() {
        let mut a = LqgDesign::ZERO;
        let mut b = a;
        a.jeff = 0.1;
        b.jeff = 0.3;
        a.ad[1][2] = -1.0;
        b.ad[1][2] = 0.7;
        let rows = [
            DesignRow {
                kind: LawKind::Lqg,
                payload_kg: 0.0,
                design: a,
            },
            DesignRow {
                kind: LawKind::SmcModal,
                payload_kg: 0.01,
                design: b,
            },
            DesignRow {
                kind: LawKind::Lqg,
                payload_kg: 0.02,
                design: b,
            },
        ];
        let mid = schedule_design(&rows, LawKind::Lqg, 0.005).unwrap();
        assert!((mid.jeff - 0.15).abs() < 1e-7 && (mid.ad[1][2] + 0.575).abs() < 1e-7);
        assert_eq!(schedule_design(&rows, LawKind::Lqg, 0.02), Some(b));
        assert_eq!(schedule_design(&rows, LawKind::Lqg, 0.0), Some(a));
        assert_eq!(schedule_design(&rows, LawKind::Lqg, -1.0), Some(a));
        assert_eq!(schedule_design(&rows, LawKind::Lqg, 1.0), Some(b));
        assert_eq!(schedule_design(&rows, LawKind::Lqg, f32::NAN), Some(a));
        assert_eq!(schedule_design(&rows, LawKind::Pd, 0.0), None);
    }

    #[test]
    fn the_compiled_table_has_smc_rows() {
        assert!(GAIN_TABLE.iter().any(|r| r.law.kind() == LawKind::Smc));
        assert!(schedule(GAIN_TABLE, LawKind::Smc, 0.0).is_some());
    }
}
