//! The drive's configuration as one value, [`DriveTable`], and gain scheduling over the
//! payload.
//!
//! A gain table (`gains.toml` in the repository, or any file a user writes) holds the plant
//! the gains were designed for, the drive's `[drive]` (its law, starting payload and
//! instruments), the gains and shapers by law and payload, and the observer laws' designs
//! made on the host. Nothing here reads a table from anywhere: whoever builds a drive builds
//! its [`DriveTable`] and passes it in. The board's is compiled in as a `const` by the
//! firmware's build; the host tools load any table at run time (the `gain-table` crate); tests
//! build small ones in code.
//!
//! [`schedule`] picks the gains for a payload, interpolating linearly between the
//! neighbouring rows of the chosen law and holding the end rows outside their range.
//! Scheduling happens when the drive is configured, not in the tick: the result is validated
//! by `ControlLaw::try_build` and swapped in whole.

use crate::beam::ParamError;
use crate::controller::ControllerSettings;
use crate::law::{ControlLaw, Law, LawKind, LawPlant, LawSet, ALL_LAWS};
pub use crate::measure::Instruments;
use crate::modal::ModalModel;
use crate::planner::Limits;
use crate::plant::{Plant, PlantPoint};
use crate::shaper::Shaper;
use beam_model::lqg::{self, LqgDesign, LqgError, LqgWeights};
use core::fmt;

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

/// Whether any of `rows` switches by tanh ([`Law::switches_by_tanh`]): a board none of
/// whose rows does leaves tanh out of its law set ([`crate::law::without_tanh`]).
pub const fn any_switches_by_tanh(rows: &[GainRow]) -> bool {
    let mut i = 0;
    while i < rows.len() {
        if rows[i].law.switches_by_tanh() {
            return true;
        }
        i += 1;
    }
    false
}

/// Why the drive's configuration could not be built for a payload.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum SetupError {
    /// The payload is outside the plant's range, 0 to [`Plant::max_payload_kg`] (the
    /// table's heaviest row).
    Payload,
    /// The gain table has no row for the law.
    NoGains,
    /// The scheduled gains are invalid for the model.
    Gains(ParamError),
}

impl fmt::Display for SetupError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            SetupError::Payload => f.write_str("the payload is outside the plant's payload range"),
            SetupError::NoGains => f.write_str("the gain table has no row for the law"),
            SetupError::Gains(e) => write!(f, "gains: {e}"),
        }
    }
}

impl core::error::Error for SetupError {}

/// The drive a gain table configures (its `[drive]`): the law it runs, the payload it starts
/// with, its instruments and its amplifier.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DriveConfig {
    /// The law the drive runs.
    pub law: LawKind,
    /// The payload it starts with, kg.
    pub payload_kg: f32,
    /// The hub encoder and the root strain converter.
    pub instruments: Instruments,
    /// Torque at 100 % PWM duty, N m (at least the plant's torque limit, so saturation never
    /// clips twice).
    pub torque_full_scale_nm: f32,
    /// Positive torque needs the amplifier's direction pin low.
    pub torque_reversed: bool,
    /// An observer law's shortest moves to a target are planned to leave its reference beam
    /// at rest (`planner::exact`), for a drive whose table was made on its own beam (a
    /// calibrated one): built in only with model-core's `exact` feature (the firmware's
    /// build refuses a table that asks for it without), and false for the other laws.
    pub exact_moves: bool,
}

impl Instruments {
    /// `model` read through these instruments: what an observer law is designed on.
    pub fn on<const N: usize>(self, model: &ModalModel<N>) -> Instrumented<'_, N> {
        Instrumented {
            model,
            instruments: self,
        }
    }
}

/// A modal model with the instruments that read it ([`Instruments::on`]): the LQG law and
/// smc-modal are designed on it, with the instruments' noise as the observer's.
#[derive(Clone, Copy, Debug)]
pub struct Instrumented<'m, const N: usize> {
    /// The model.
    pub model: &'m ModalModel<N>,
    /// The instruments.
    pub instruments: Instruments,
}

impl<const N: usize> LawPlant for Instrumented<'_, N> {
    fn point(&self) -> PlantPoint {
        PlantPoint::of(self.model)
    }

    fn lqg(&self, weights: &LqgWeights, ts_s: f64) -> Option<Result<LqgDesign, LqgError>> {
        if !cfg!(feature = "observer") {
            return None;
        }
        let noise = self.instruments.noise();
        // On the first `LQG_MODES` modes: a controller that also observes the higher modes
        // tracks them on the model's frequencies, and a beam a few percent off those turns
        // them unstable (spillover; with 1 % damping there is no margin to spare). Left out,
        // they see a gain that has rolled off by their frequencies. A model with fewer modes
        // is designed on as it is.
        Some(lqg::design_leading(self.model, weights, &noise, ts_s))
    }
}

/// A bare modal model: the plant point for the laws that need no more. An observer law on
/// it is refused ([`ParamErrorKind::NeedsModel`](crate::beam::ParamErrorKind::NeedsModel)):
/// its design needs the instruments that read the beam ([`Instruments::on`]), and none are
/// assumed.
impl<const N: usize> LawPlant for &ModalModel<N> {
    fn point(&self) -> PlantPoint {
        PlantPoint::of(*self)
    }
}

/// The drive's whole configuration: the plant it is built for, its `[drive]`, the gain
/// table's rows (grouped by law, each law's sorted by payload) and the observer laws' designs
/// made on the host at the plant's payloads. Built once, outside the loop, and passed to
/// whatever builds a controller or a command handler from it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DriveTable<'t> {
    /// The plant on its payload grid.
    pub plant: &'t Plant,
    /// The `[drive]`.
    pub drive: DriveConfig,
    /// The gains and shapers, by law and payload.
    pub rows: &'t [GainRow],
    /// The observer laws' designs, by law and payload ([`schedule_design`]); empty for a
    /// table without observer laws.
    pub designs: &'t [DesignRow],
}

impl<'t> DriveTable<'t> {
    /// The gains of law `kind` at `payload_kg` ([`scheduled_law`]).
    pub fn law(&self, kind: LawKind, payload_kg: f32) -> Option<Law> {
        scheduled_law(self.rows, kind, payload_kg)
    }

    /// The input shaper of law `kind` at `payload_kg` ([`schedule_shaper`]).
    pub fn shaper(&self, kind: LawKind, payload_kg: f32) -> Shaper {
        schedule_shaper(self.rows, kind, payload_kg)
    }

    /// The plant at `payload_kg` with, for an observer law `kind`, its design scheduled on
    /// the payload; `None` outside the plant's payloads.
    pub fn designed_plant(&self, kind: LawKind, payload_kg: f32) -> Option<DesignedPlant> {
        Some(DesignedPlant {
            point: self.plant.at(payload_kg)?,
            design: schedule_design(self.designs, kind, payload_kg),
        })
    }

    /// Law `kind` at `payload_kg`, validated and built on the plant there (with its design,
    /// for an observer law). Without the `observer` feature an observer law is refused
    /// whatever the designs, and nothing of them is linked.
    pub fn build_law(&self, kind: LawKind, payload_kg: f32) -> Result<ControlLaw, SetupError> {
        self.build_law_in::<ALL_LAWS>(kind, payload_kg)
    }

    /// [`DriveTable::build_law`] in a build that holds the laws `LAWS` ([`LawSet`]): the
    /// board's, which holds its own law alone.
    pub fn build_law_in<const LAWS: LawSet>(
        &self,
        kind: LawKind,
        payload_kg: f32,
    ) -> Result<ControlLaw, SetupError> {
        let gains = self.law(kind, payload_kg).ok_or(SetupError::NoGains)?;
        #[cfg(feature = "observer")]
        let law = {
            let plant = self
                .designed_plant(kind, payload_kg)
                .ok_or(SetupError::Payload)?;
            ControlLaw::try_build_in::<LAWS>(gains, plant)
        };
        #[cfg(not(feature = "observer"))]
        let law = {
            let point = self.plant.at(payload_kg).ok_or(SetupError::Payload)?;
            ControlLaw::try_build_in::<LAWS>(gains, point)
        };
        law.map_err(SetupError::Gains)
    }

    /// What a command handler runs law `kind` with at `payload_kg`: the law
    /// ([`DriveTable::build_law_in`], in the build's law set `LAWS`), its shaper and the
    /// planner's limits (with what the observer laws ask of the planner: a floor on a
    /// move's length, a number of the beam's first periods there, and a strain budget).
    pub fn configure<const LAWS: LawSet>(
        &self,
        kind: LawKind,
        payload_kg: f32,
    ) -> Result<(ControlLaw, Shaper, Limits), SetupError> {
        let law = self.build_law_in::<LAWS>(kind, payload_kg)?;
        let point = self.plant.at(payload_kg).ok_or(SetupError::Payload)?;
        #[allow(unused_mut)]
        let mut limits = Limits::for_plant(point);
        // Only the observer laws ask for a floor or a strain budget (the board built without
        // them has no flash to spare for this).
        #[cfg(feature = "observer")]
        {
            let periods = law.law().min_move_periods();
            if periods > 0.0 {
                if let Some(hz) = self.plant.first_hz_at(payload_kg).filter(|&hz| hz > 0.0) {
                    limits.min_segment_s = periods / hz;
                }
            }
            limits.strain_budget = law.law().planned_strain();
        }
        // The shortest moves of an observer law planned to leave its reference beam at rest,
        // where the table asks for them.
        #[cfg(feature = "exact")]
        if self.drive.exact_moves {
            limits = limits.with_reference_beam(&law, self.settings(0.0).ts_s);
        }
        Ok((law, self.shaper(kind, payload_kg), limits))
    }

    /// The loop's settings for this drive: its instruments and the plant's torque limit,
    /// with the counter zeroed at `home_rad`; the rest at [`ControllerSettings::new`]'s.
    pub fn settings(&self, home_rad: f32) -> ControllerSettings {
        ControllerSettings {
            theta_home_rad: home_rad,
            torque_limit_nm: self.plant.params.torque_limit_nm as f32,
            ..ControllerSettings::new(self.drive.instruments)
        }
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

/// The design of law `kind` at `payload_kg` from `rows`: the law's rows taken in threes
/// from its first (`0, 1, 2`, `2, 3, 4`, ...), and the quadratic through the three about the
/// payload, by Neville's scheme of three linear mixes ([`LqgDesign::mix`]); an odd row out
/// at the end mixed linearly with the one before, and the end rows held outside their range;
/// `None` without a row of that law. The host makes the rows so that no three straddle a row
/// of gains (docs/design-gains.md, "The observer designs between payloads"): a design follows
/// its gains, which bend at their rows.
#[inline(never)] // one copy for the board, which builds a law in two places (docs/results.md)
pub fn schedule_design(rows: &[DesignRow], kind: LawKind, payload_kg: f32) -> Option<LqgDesign> {
    let mut rows = rows.iter().filter(|r| r.kind == kind);
    let mut a = rows.next()?;
    if !(payload_kg > a.payload_kg) {
        return Some(a.design);
    }
    let p = payload_kg;
    let f = |lo: &DesignRow, hi: &DesignRow| (p - lo.payload_kg) / (hi.payload_kg - lo.payload_kg);
    loop {
        let Some(m) = rows.next() else {
            return Some(a.design);
        };
        // At a row, its design exactly (a mix with weight 1 can round apart from it).
        if p == m.payload_kg {
            return Some(m.design);
        }
        let Some(b) = rows.next() else {
            return Some(if p < m.payload_kg {
                a.design.mix(&m.design, f(a, m))
            } else {
                m.design
            });
        };
        if p == b.payload_kg {
            return Some(b.design);
        }
        if p < b.payload_kg {
            let low = a.design.mix(&m.design, f(a, m));
            let high = m.design.mix(&b.design, f(m, b));
            return Some(low.mix(&high, f(a, b)));
        }
        a = b;
    }
}

/// A drive's plant at its payload with, for an observer law, the design made on the
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

    fn lqg(&self, _: &LqgWeights, _: f64) -> Option<Result<LqgDesign, LqgError>> {
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
#[inline(never)] // as schedule_design
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
pub(crate) mod tests {
    use super::*;

    /// The aluminium beam's plant (3 modes) on a grid to 50 g, computed here and leaked.
    pub(crate) fn plant() -> &'static Plant {
        use crate::beam::{Beam, BeamParams};
        let params = BeamParams::aluminium();
        let model = |kg: f64| {
            let beam = Beam::try_build(BeamParams {
                tip_mass_kg: kg,
                ..params
            })
            .unwrap();
            ModalModel::<3>::try_build(&beam).unwrap()
        };
        let grid: Vec<(f32, f32)> = (0..=4)
            .map(|i| {
                let kg = (0.0125 * i as f64) as f32;
                (kg, model(kg as f64).clamped_hz[0] as f32)
            })
            .collect();
        let first_hz = Box::leak(grid.into_boxed_slice());
        Box::leak(Box::new(Plant::from_models(
            params,
            &model(0.0),
            &model(1.0),
            first_hz,
        )))
    }

    /// Rows of law `kind` at its starting gains, unshaped, at `payloads` (leaked).
    pub(crate) fn rows(kind: LawKind, payloads: &[f32]) -> &'static [GainRow] {
        let rows: Vec<GainRow> = payloads
            .iter()
            .map(|&payload_kg| GainRow {
                payload_kg,
                law: Law::start(kind),
                shaper: Shaper::NONE,
            })
            .collect();
        Box::leak(rows.into_boxed_slice())
    }

    /// A drive on [`plant`] with `rows`, the reference instruments and no designs.
    pub(crate) fn table(rows: &'static [GainRow]) -> &'static DriveTable<'static> {
        Box::leak(Box::new(DriveTable {
            plant: plant(),
            drive: DriveConfig {
                law: rows[0].law.kind(),
                payload_kg: 0.0,
                instruments: Instruments::DEFAULT,
                torque_full_scale_nm: 10.0,
                torque_reversed: false,
                exact_moves: false,
            },
            rows,
            designs: &[],
        }))
    }

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

    /// Through three rows the schedule is the quadratic through them: exact (to f32) on an
    /// entry that is a quadratic in the payload, at every payload between, on uneven rows;
    /// the rows themselves exactly; past the last three, a fourth row mixed linearly.
    #[test]
    fn designs_are_scheduled_on_the_quadratic_through_three_rows() {
        let q = |p: f32| 0.3 - 20.0 * p + 4000.0 * p * p;
        let row = |payload_kg: f32| {
            let mut design = LqgDesign::ZERO;
            design.jeff = q(payload_kg);
            design.k[0] = payload_kg;
            DesignRow {
                kind: LawKind::SmcModal,
                payload_kg,
                design,
            }
        };
        let rows = [row(0.0), row(0.004), row(0.0125), row(0.02)];
        for i in 0..=40 {
            let p = 0.0125 * i as f32 / 40.0;
            let d = schedule_design(&rows, LawKind::SmcModal, p).unwrap();
            assert!(
                (d.jeff - q(p)).abs() < 2e-6,
                "at {p}: {} for {}",
                d.jeff,
                q(p)
            );
            assert!((d.k[0] - p).abs() < 1e-8, "at {p}: {}", d.k[0]);
        }
        for r in &rows {
            assert_eq!(
                schedule_design(&rows, LawKind::SmcModal, r.payload_kg),
                Some(r.design)
            );
        }
        // The fourth row, past the first three: linear between the third and it.
        let d = schedule_design(&rows, LawKind::SmcModal, 0.016_25).unwrap();
        let linear = 0.5 * (q(0.0125) + q(0.02));
        assert!((d.jeff - linear).abs() < 1e-6 && (d.jeff - q(0.016_25)).abs() > 1e-3);
        assert_eq!(
            schedule_design(&rows, LawKind::SmcModal, 0.03),
            Some(rows[3].design)
        );
        assert_eq!(schedule_design(&rows, LawKind::Lqg, 0.01), None);
    }

    /// An observer law is designed on the instruments it is given: a coarser encoder is a
    /// noisier hub angle, so the Kalman filter leans less on it (its gain on the angle drops),
    /// and on a bare model, with no instruments, the law is refused rather than designed on
    /// some default.
    #[cfg(feature = "observer")]
    #[test]
    fn two_rigs_with_different_encoders_get_different_observer_designs() {
        use crate::law::{LawGains, LqgGains};
        use crate::measure::EncoderSpec;
        let model = crate::law::tests::model();
        let design = |counts_per_rev| {
            let instruments = Instruments {
                encoder: EncoderSpec {
                    counts_per_rev,
                    ..EncoderSpec::DEFAULT
                },
                ..Instruments::DEFAULT
            };
            let law = ControlLaw::try_build(LqgGains::START.law(), instruments.on(&model));
            *law.unwrap().observer_design().unwrap()
        };
        let (fine, coarse) = (design(16384), design(1024));
        assert_ne!(fine, coarse);
        // The angle's row of the observer gain: the hub angle's own correction is smaller
        // when the angle is 16 times coarser.
        assert!(
            coarse.l[0][0].abs() < fine.l[0][0].abs(),
            "{:?} {:?}",
            coarse.l[0],
            fine.l[0]
        );
        let bare = ControlLaw::try_build(LqgGains::START.law(), &model).unwrap_err();
        assert_eq!(bare.kind, crate::beam::ParamErrorKind::NeedsModel);
    }
}
