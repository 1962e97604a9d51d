//! The control laws: the paper's sliding-mode controller, the strain-augmented variant, the
//! PD baseline, feedforward plus PD, the integral sliding mode and LQG on a modal observer
//! (docs/design.md, section 4).
//!
//! Each law is defined once, in its own file: its gain type (declared with `gains!`, whose
//! fields the compiler checks against the law's specs in beam-kinds), the gains it starts
//! from, what it folds in from the plant ([`LawGains::build`]) and the torque it commands
//! ([`LawGains::torque_nm`]). The list in `laws!` below makes [`Law`] and its dispatch from
//! them, so adding a law is its file, its name and specs in `beam_kinds::LawKind`, and one
//! line there. The gain table, the interpolation over payloads, the optimiser's search
//! vector, the CLI and JSON all go through [`Law::values`], [`Law::settings`] and
//! [`Law::from_values`], in the specs' order, and never name a law's fields.
//!
//! [`Law`] is what a user chooses (gains and variant); [`ControlLaw::try_build`] validates it
//! against a [`ModalModel`] once and folds the model into a few `f32` constants, so the
//! per-tick [`ControlLaw::torque_nm`] is a handful of multiply-adds and one `tanhf`.

use crate::beam::{ParamError, ParamErrorKind};
#[cfg(doc)]
use crate::modal::ModalModel;
use crate::plant::PlantPoint;
use crate::spline::RefPoint;
use beam_kinds::GainRule;
use beam_model::lqg::{LqgDesign, LqgError, LqgWeights};

pub use beam_kinds::{GainSpec, LawKind, Search, Setting, Settings, Sign, Switching, MAX_GAINS};

mod lqg;
mod pd;
mod pd_ff;
mod smc;
mod smc_i;
mod smc_modal;
mod smc_strain;

#[cfg(feature = "identify")]
pub use lqg::{
    clamped_coupling, Adaptation, Identifier, COMPLIANCE_BLEND_PER_TICK, COMPLIANCE_FADE_STRAIN,
    IDENTIFY_DEAD_BAND, IDENTIFY_RANGE, IDENTIFY_TICKS,
};
#[cfg(feature = "observer")]
pub use lqg::{DesignOptions, ObserverState, MOVE_FADE_PER_TICK, MOVE_FADE_S};
pub use lqg::{
    LqgGains, ASSUMED_STRAIN_NOISE, FEEDBACK_LOWPASS_ALPHA, FEEDBACK_LOWPASS_HZ,
    INTEGRAL_MAX_RATE_RAD_S, LQG_MODES, RING_STEP,
};
pub use pd::PdGains;
pub use pd_ff::PdFfGains;
pub use smc::SmcGains;
pub use smc_i::SmcIGains;
pub use smc_modal::{
    SmcModalGains, SMC_MODAL_KD, SMC_MODAL_MOVE_RATE, SMC_MODAL_MOVE_RATE_PAYLOAD_KG,
    SMC_MODAL_MOVE_RATE_UNLOADED, SMC_MODAL_REST_KP_FACTOR,
};
pub use smc_strain::StrainSmcGains;

/// Defines a law's gain type: its gains as `f32` fields, named and ordered as the law's
/// specs ([`LawKind::gain_names`]), then its settings ([`LawKind::settings`]), both checked
/// at compile time; and the `const fn`s [`Law::values`], [`Law::settings`] and
/// [`Law::from_values`] go through.
macro_rules! gains {
    (
        $(#[$meta:meta])*
        pub struct $ty:ident for $kind:ident {
            $( $(#[$fmeta:meta])* $field:ident, )+
        }
        $( settings { $( $(#[$smeta:meta])* $setting:ident: $sty:ty = $variant:ident, )+ } )?
    ) => {
        $(#[$meta])*
        #[derive(Clone, Copy, Debug, PartialEq)]
        #[cfg_attr(feature = "defmt", derive(defmt::Format))]
        pub struct $ty {
            $( $(#[$fmeta])* pub $field: f32, )+
            $($( $(#[$smeta])* pub $setting: $sty, )+)?
        }

        impl $crate::law::GainLayout for $ty {
            const KIND: $crate::law::LawKind = $crate::law::LawKind::$kind;

            fn from_law(law: &$crate::law::Law) -> Self {
                Self::from_values(law.values(), law.settings())
            }
        }

        impl $ty {
            /// The gains in the order of the law's specs, zero past them.
            pub const fn values(&self) -> [f32; $crate::law::MAX_GAINS] {
                let mut v = [0.0; $crate::law::MAX_GAINS];
                let [$($field,)+ ..] = &mut v;
                $( *$field = self.$field; )+
                v
            }

            /// The law's settings; those it does not have at their defaults.
            pub const fn settings(&self) -> $crate::law::Settings {
                #[allow(unused_mut)]
                let mut s = $crate::law::Settings::DEFAULT;
                $($( s.$setting = self.$setting; )+)?
                s
            }

            /// The gains from values in the order of the law's specs and the settings (the
            /// law reads only its own).
            pub const fn from_values(
                values: [f32; $crate::law::MAX_GAINS],
                settings: $crate::law::Settings,
            ) -> Self {
                let [$($field,)+ ..] = values;
                let _ = settings;
                Self { $($field,)+ $($( $setting: settings.$setting, )+)? }
            }
        }

        const _: () = assert!(
            beam_kinds::same_names(&[$(stringify!($field)),+], $crate::law::LawKind::$kind.gain_names()),
            concat!(stringify!($ty), "'s fields must be ", stringify!($kind), "'s gain names, in order")
        );
        const _: () = assert!(
            beam_kinds::same_settings(
                &[$($(beam_kinds::Setting::$variant),+)?],
                $crate::law::LawKind::$kind.settings(),
            ),
            concat!(stringify!($ty), "'s settings must be ", stringify!($kind), "'s, in order")
        );
    };
}
use gains;

/// What `gains!` defines for each gain type.
pub trait GainLayout: Copy {
    /// The law these gains are for.
    const KIND: LawKind;

    /// The gains of `law`, read as this type (whatever its kind; see [`Law::gains`]).
    fn from_law(law: &Law) -> Self;
}

/// What each law's file defines beside its gain type. [`Law`] dispatches to it.
pub trait LawGains: GainLayout {
    /// The gains the law runs when neither the command line nor the gain table gives them.
    const START: Self;
    /// How many of the beam's first clamped periods a planned move lasts at least, when
    /// the planner picks its time; 0 for no floor ([`Law::min_move_periods`]).
    const MIN_MOVE_PERIODS: f32 = 0.0;
    /// The root strain the planner holds the law's shortest moves within, on the beam bent
    /// statically by the move's peak acceleration; 0 for none ([`Law::planned_strain`]).
    const PLANNED_STRAIN: f32 = 0.0;

    /// What the law needs of the plant, folded into `plain` (the law on `point` with Jeff
    /// as its inertia and Mtt as the rigid inertia, the gains' signs checked). The default
    /// needs nothing more. `plant` is what the law is built on, for a law that designs on
    /// a whole model.
    fn build(
        &self,
        plain: ControlLaw,
        point: &PlantPoint,
        plant: &impl LawPlant,
    ) -> Result<ControlLaw, ParamError> {
        let _ = (point, plant);
        Ok(plain)
    }

    /// The unsaturated torque command, N m; see [`ControlLaw::torque_nm`].
    fn torque_nm(
        &self,
        law: &ControlLaw,
        x: &Estimate,
        r: &RefPoint,
        state: &mut LawState,
        ts_s: f32,
    ) -> f32;
}

/// A set of laws, a bit per [`LawKind`] (by its discriminant), and one for the tanh
/// switching function ([`TANH_SWITCHING`]): which laws a build holds, and whether it can
/// switch by tanh. The host holds them all ([`ALL_LAWS`]); a board holds its table's law
/// alone ([`only`]`(kind)`, less tanh where its rows do not use it), passed down as a const
/// generic (`ControlLaw::try_build_in`, `Controller::step_in`), so the other laws' arms are
/// dropped from the dispatch and their code is not in its binary. A law not in the set is
/// refused when it is built ([`ParamErrorKind::NotBuiltIn`]).
pub type LawSet = u8;

/// Every law.
pub const ALL_LAWS: LawSet = LawSet::MAX;

/// The set's bit past the laws' own: the sliding-mode laws' tanh switching function
/// ([`Switching::Tanh`]). libm's `tanhf` and the `expm1f` it calls are 0.7 KB of the drive's
/// flash (736 B on the smc-modal board), which a board whose rows all switch otherwise
/// (smc-modal's `sat`) leaves out ([`without_tanh`]); a law that asks for tanh is then
/// refused when it is built, as a law not built in is.
pub const TANH_SWITCHING: LawSet = 1 << (LawSet::BITS - 1);

/// The set of law `kind` alone, with every switching function.
pub const fn only(kind: LawKind) -> LawSet {
    law_bit(kind) | TANH_SWITCHING
}

/// `laws` without the tanh switching function ([`TANH_SWITCHING`]).
pub const fn without_tanh(laws: LawSet) -> LawSet {
    laws & !TANH_SWITCHING
}

/// Whether the set `laws` holds law `kind`. A constant wherever `kind` is, so the dispatch
/// below drops the other laws' arms.
pub const fn holds(laws: LawSet, kind: LawKind) -> bool {
    laws & law_bit(kind) != 0
}

const fn law_bit(kind: LawKind) -> LawSet {
    1 << kind as u8
}

// A bit per law, below the switching's.
const _: () = assert!(LawKind::ALL.len() < LawSet::BITS as usize);

/// Makes [`Law`]'s constructors and dispatch from the list of laws.
macro_rules! laws {
    ($( $(#[$meta:meta])* $kind:ident($gains:ident), )+) => {
        $(
            impl From<$gains> for Law {
                fn from(g: $gains) -> Law {
                    g.law()
                }
            }

            impl $gains {
                /// The law running these gains.
                pub const fn law(self) -> Law {
                    Law {
                        kind: LawKind::$kind,
                        values: self.values(),
                        settings: self.settings(),
                    }
                }
            }
        )+

        #[allow(non_snake_case)]
        impl Law {
            $(
                $(#[$meta])*
                pub const fn $kind(gains: $gains) -> Law {
                    gains.law()
                }
            )+

            /// Law `kind` with gains `values` in the order of its specs and `settings` (the
            /// law reads only its own): what a gain table, the interpolation and the
            /// tools build laws with.
            pub const fn from_values(kind: LawKind, values: [f32; MAX_GAINS], settings: Settings) -> Law {
                match kind {
                    $( LawKind::$kind => $gains::from_values(values, settings).law(), )+
                }
            }

            /// Law `kind` with the gains it starts from ([`LawGains::START`]).
            pub const fn start(kind: LawKind) -> Law {
                match kind {
                    $( LawKind::$kind => <$gains as LawGains>::START.law(), )+
                }
            }

            /// How many of the beam's first clamped periods a planned move lasts at least,
            /// when the planner picks its time ([`crate::Limits::for_law`]); 0 for no floor.
            pub const fn min_move_periods(&self) -> f32 {
                match self.kind {
                    $( LawKind::$kind => <$gains as LawGains>::MIN_MOVE_PERIODS, )+
                }
            }

            /// The root strain the planner holds a move within when it picks its time
            /// ([`crate::Limits::strain_budget`]), strain; 0 for none.
            pub const fn planned_strain(&self) -> f32 {
                match self.kind {
                    $( LawKind::$kind => <$gains as LawGains>::PLANNED_STRAIN, )+
                }
            }

            fn build<const LAWS: LawSet>(
                &self,
                plain: ControlLaw,
                point: &PlantPoint,
                plant: &impl LawPlant,
            ) -> Result<ControlLaw, ParamError> {
                let (v, s) = (self.values, self.settings);
                match self.kind {
                    $(
                        LawKind::$kind if const { holds(LAWS, LawKind::$kind) } => {
                            $gains::from_values(v, s).build(plain, point, plant)
                        }
                    )+
                    kind => Err(ParamError {
                        field: kind.name(),
                        kind: ParamErrorKind::NotBuiltIn,
                    }),
                }
            }

            #[inline(always)]
            fn torque_nm<const LAWS: LawSet>(
                &self,
                law: &ControlLaw,
                x: &Estimate,
                r: &RefPoint,
                state: &mut LawState,
                ts_s: f32,
            ) -> f32 {
                let (v, mut s) = (self.values, self.settings);
                // Without tanh in the set no law here switches by it (`try_build_in` refused
                // it); saying so lets the switching's tanh arm, and libm's tanhf, go.
                if LAWS & TANH_SWITCHING == 0 && s.switching == Switching::Tanh {
                    s.switching = Switching::Sat;
                }
                match self.kind {
                    $(
                        LawKind::$kind if const { holds(LAWS, LawKind::$kind) } => {
                            $gains::from_values(v, s).torque_nm(law, x, r, state, ts_s)
                        }
                    )+
                    // A law not built in is refused when it is built (`build` above), so no
                    // `ControlLaw` of it exists to get here.
                    _ => 0.0,
                }
            }
        }
    };
}

/// Which law runs, with its gains: the law, its gains in the order of its specs
/// ([`LawKind::gains`], zero past them) and its settings (those it does not have at their
/// defaults). One layout for every law, so the table, the interpolation and the tools handle
/// gains by name and position; each law's file reads them as its own gain type, which after
/// inlining is a load per gain. Made by [`Law::from_values`], from a gain type
/// ([`SmcGains::law`], `Law::from`) or by the law's name (`Law::Smc(gains)`).
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Law {
    kind: LawKind,
    values: [f32; MAX_GAINS],
    settings: Settings,
}

laws! {
    /// The PD baseline.
    Pd(PdGains),
    /// The paper's SMC: output theta, model terms zero, `[C M^-1 B]^-1 = Jeff`.
    Smc(SmcGains),
    /// The strain-augmented SMC on y = theta + c eps_root.
    SmcStrain(StrainSmcGains),
    /// Rigid-body feedforward plus PD.
    PdFf(PdFfGains),
    /// The integral sliding mode with rigid-body feedforward.
    SmcI(SmcIGains),
    /// LQR with integral action on a Kalman modal observer, with rigid-body feedforward.
    Lqg(LqgGains),
    /// The sliding mode on the full observed state (the LQR's surface), on the LQG observer.
    SmcModal(SmcModalGains),
}

impl Law {
    /// Which law this is.
    pub const fn kind(&self) -> LawKind {
        self.kind
    }

    /// The gains' values in the order of their specs, [`LawKind::gains`] (the first
    /// `gains().len()` entries; the rest zero).
    pub const fn values(&self) -> [f32; MAX_GAINS] {
        self.values
    }

    /// The law's settings (those it does not have at their defaults).
    pub const fn settings(&self) -> Settings {
        self.settings
    }

    /// Whether the law switches by tanh ([`TANH_SWITCHING`]): it has a switching function
    /// and it is [`Switching::Tanh`] (the setting's default, which a law without one carries
    /// unused).
    pub const fn switches_by_tanh(&self) -> bool {
        let settings = self.kind.settings();
        let mut i = 0;
        while i < settings.len() {
            if matches!(settings[i], Setting::Switching) {
                return matches!(self.settings.switching, Switching::Tanh);
            }
            i += 1;
        }
        false
    }

    /// This law with its settings and other gain values, in the specs' order (zero past
    /// them): for a mix of two of its rows, which needs no dispatch on the law.
    pub(crate) const fn with_values(&self, values: [f32; MAX_GAINS]) -> Law {
        Law { values, ..*self }
    }

    /// The gains as law `G`'s gain type, if this is that law.
    pub fn gains<G: LawGains>(&self) -> Option<G> {
        (self.kind == G::KIND).then(|| G::from_law(self))
    }

    /// The law's name on the command line and in tables: its kind's name.
    pub const fn name(&self) -> &'static str {
        self.kind().name()
    }

    /// Checks every gain against its spec's sign rule ([`LawKind::gains`], the rule the gain
    /// table's build applies too).
    pub fn check(&self) -> Result<(), ParamError> {
        let (kind, values) = (self.kind(), self.values());
        let rules = kind.gain_names().iter().zip(kind.gain_signs());
        for ((&field, sign), &v) in rules.zip(&values) {
            sign.check(v as f64).map_err(|rule| ParamError {
                field,
                kind: match rule {
                    GainRule::NonFinite => ParamErrorKind::NonFinite,
                    GainRule::NotPositive => ParamErrorKind::NotPositive,
                    GainRule::Negative => ParamErrorKind::Negative,
                },
            })?;
        }
        Ok(())
    }
}

/// The measured state the laws use, SI.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Estimate {
    /// Hub angle, rad.
    pub theta: f32,
    /// Hub velocity, rad/s (filtered).
    pub omega: f32,
    /// Root strain (dimensionless).
    pub strain: f32,
    /// Root strain rate, 1/s (filtered).
    pub strain_rate: f32,
}

/// What a law carries from one tick to the next: the integral of the hub error (smc-i, lqg)
/// and the observer's state (lqg, smc-modal). Cleared when a move is armed
/// ([`LawState::restart`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct LawState {
    /// Integral of `theta - theta_r` since the move started, rad s.
    pub integral: f32,
    /// The observer and reference beam of lqg and smc-modal.
    #[cfg(feature = "observer")]
    pub lqg: ObserverState,
}

impl LawState {
    /// Ready for a new move: the same as [`LawState::default`]. Called when a move is armed
    /// ([`crate::Controller::start_move`]), on the command path: the move's first tick, the
    /// observer laws' worst, then has only the observer's angle to set.
    #[inline]
    pub fn restart(&mut self, law: &ControlLaw) {
        *self = LawState::default();
        #[cfg(feature = "identify")]
        {
            self.lqg.adaptation = lqg::Adaptation::start(&law.observer);
        }
        #[cfg(not(feature = "identify"))]
        let _ = law;
    }
}

/// What a law is built on: the plant at the drive's payload ([`PlantPoint`], what a drive
/// carries compiled in), or a whole modal model, on which the LQG law is designed too.
pub trait LawPlant {
    /// The plant's numbers the laws read.
    fn point(&self) -> PlantPoint;
    /// The LQG design for `weights` on this plant, sampled at `ts_s`; `None` if this plant
    /// cannot design one (a [`PlantPoint`], a bare [`ModalModel`]). A modal model read
    /// through instruments (`crate::table::Instrumented`) designs it with their noise.
    fn lqg(&self, _weights: &LqgWeights, _ts_s: f64) -> Option<Result<LqgDesign, LqgError>> {
        None
    }
}

impl LawPlant for PlantPoint {
    fn point(&self) -> PlantPoint {
        *self
    }
}

/// gamma = e' Mqq^-1 h, how much a hub acceleration shows in the root strain of the held
/// beam: the blended output y = theta + c eps_root has the input gain (1 - c gamma) / Jeff.
pub fn strain_coupling(plant: impl Into<PlantPoint>) -> f32 {
    plant.into().strain_coupling()
}

/// `1 - c gamma`, refused below [`PlantPoint::MIN_BLEND_RATIO`], where the blend would take
/// the output's control direction away.
fn input_gain_ratio(c: f32, m: &PlantPoint) -> Result<f32, ParamError> {
    m.blend_ratio(c).ok_or(ParamError {
        field: "c",
        kind: ParamErrorKind::OutOfRange,
    })
}

/// A validated law folded with the model constants it needs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ControlLaw {
    law: Law,
    /// Jeff for the paper law; [C M^-1 B]^-1 for the strain law, kg m^2.
    inertia: f32,
    /// Mtt, the whole rigid inertia, for the laws with rigid-body feedforward, kg m^2.
    rigid_inertia: f32,
    /// The integral's bound (smc-i, lqg): the integral cannot wind up past what the
    /// drive's torque limit can use.
    integral_max: f32,
    /// Model-term coefficients (strain law with `model_terms`).
    model: smc_strain::ModelTerms,
    /// The LQG design (lqg; all zero for the other laws).
    #[cfg(feature = "observer")]
    observer: LqgDesign,
}

impl ControlLaw {
    /// Validates `law`'s gains and precomputes what the tick needs from the plant: a
    /// [`PlantPoint`] (a drive's plant at its payload), a [`ModalModel`], or a modal model
    /// read through instruments (`crate::table::Instruments::on`). The observer laws are
    /// designed on the last only (sampled at [`crate::DEFAULT_TS_S`], with the instruments'
    /// noise as the observer's); on the others they are refused.
    #[inline(always)] // the call is to `try_build_in`
    pub fn try_build(law: Law, plant: impl LawPlant) -> Result<Self, ParamError> {
        Self::try_build_in::<ALL_LAWS>(law, plant)
    }

    /// [`ControlLaw::try_build`] in a build that holds the laws `LAWS` ([`LawSet`]): a law
    /// outside them is refused, and no other law's code is linked.
    #[inline(never)] // one copy per plant type: the board builds a law in two places
    pub fn try_build_in<const LAWS: LawSet>(
        law: Law,
        plant: impl LawPlant,
    ) -> Result<Self, ParamError> {
        let point = plant.point();
        let plain = Self {
            law,
            inertia: point.jeff,
            rigid_inertia: point.mtt,
            integral_max: 0.0,
            model: smc_strain::ModelTerms::default(),
            #[cfg(feature = "observer")]
            observer: lqg::NO_OBSERVER,
        };
        // Every gain's sign, by the law's spec; then what the law needs of the plant (or
        // the switching function it asks for, where the build left tanh out: "`tanh` is not
        // built into this drive").
        law.check()?;
        if LAWS & TANH_SWITCHING == 0 && law.switches_by_tanh() {
            return Err(ParamError {
                field: Switching::Tanh.name(),
                kind: ParamErrorKind::NotBuiltIn,
            });
        }
        law.build::<LAWS>(plain, &point, &plant)
    }

    /// The law as chosen.
    pub fn law(&self) -> &Law {
        &self.law
    }

    /// The rigid inertia of hub, beam and payload about the axis the law was built on
    /// (`Mtt`), kg m^2: the drive's brake feeds it forward
    /// ([`Brake`](crate::controller::Brake)).
    pub fn rigid_inertia(&self) -> f32 {
        self.rigid_inertia
    }

    /// The observer's design the law was built with (lqg, smc-modal); `None` for the others.
    #[cfg(feature = "observer")]
    pub fn observer_design(&self) -> Option<&LqgDesign> {
        self.law.kind().has_observer().then_some(&self.observer)
    }

    /// The unsaturated torque command for the estimate `x` and reference `r`, N m, advancing
    /// the law's own state (the integral of smc-i) by one tick of `ts_s`. May be non-finite
    /// only if `x` or `r` is; the caller guards and saturates. Always inlined: with two
    /// controllers in one binary (the PIL drive's sequence and commanded paths) a plain
    /// hint let it be outlined, which cost about 30 instructions a tick.
    #[inline(always)]
    pub fn torque_nm(&self, x: &Estimate, r: &RefPoint, state: &mut LawState, ts_s: f32) -> f32 {
        self.torque_nm_in::<ALL_LAWS>(x, r, state, ts_s)
    }

    /// [`ControlLaw::torque_nm`] dispatched over the laws `LAWS` only (the set the law was
    /// built in, [`ControlLaw::try_build_in`]).
    #[inline(always)]
    pub fn torque_nm_in<const LAWS: LawSet>(
        &self,
        x: &Estimate,
        r: &RefPoint,
        state: &mut LawState,
        ts_s: f32,
    ) -> f32 {
        self.law.torque_nm::<LAWS>(self, x, r, state, ts_s)
    }
}

/// `|z| <= limit / per_z`: the bound on an integral `z` whose torque is `per_z |z|`, so it
/// cannot wind up past what the drive's `limit` can use (0, no integral, when `per_z` is 0).
fn integral_bound(limit: f32, per_z: f32) -> f32 {
    if per_z > 0.0 {
        limit / per_z
    } else {
        0.0
    }
}

/// `z + e ts` within `+-m`. Comparisons, not clamp/min/max (an assertion or a library call
/// on the M4F).
#[inline(always)]
fn integrate(z: f32, e: f32, ts_s: f32, m: f32) -> f32 {
    let z = z + e * ts_s;
    if z > m {
        m
    } else if z < -m {
        -m
    } else {
        z
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::beam::{Beam, BeamParams};
    use crate::modal::ModalModel;

    #[test]
    fn the_feedback_low_pass_step_is_its_corner_at_the_drives_tick() {
        // 1 - exp(-2 pi f ts), in f64, against the f32 step the tick uses.
        let (f, ts) = (FEEDBACK_LOWPASS_HZ as f64, crate::DEFAULT_TS_S as f64);
        let alpha = 1.0 - libm::exp(-2.0 * core::f64::consts::PI * f * ts);
        assert!(
            (alpha - FEEDBACK_LOWPASS_ALPHA as f64).abs() < 1e-4,
            "{alpha}"
        );
    }

    #[cfg(feature = "observer")]
    #[test]
    fn the_moving_regulators_fade_is_its_time_constant_at_the_drives_tick() {
        let step = libm::exp(-(crate::DEFAULT_TS_S as f64) / MOVE_FADE_S as f64);
        assert!((step - MOVE_FADE_PER_TICK as f64).abs() < 1e-7, "{step}");
    }

    /// The identifier's bias correction, `k - b (k - 1)^2`, peaks where the step is held at
    /// its stiffest, and is the range's top there: it rises with every step the identifier
    /// takes, and never leaves the range.
    #[cfg(feature = "identify")]
    #[test]
    fn the_identifiers_correction_rises_to_the_ranges_top_where_the_step_is_held() {
        use lqg::identify::{IDENTIFY_STEP_BIAS as B, IDENTIFY_STEP_MAX as MAX};
        let corrected = |k: f32| k - B * (k - 1.0) * (k - 1.0);
        assert_eq!(1.0 - 2.0 * B * (MAX - 1.0), 0.0, "the slope at the top");
        assert_eq!(corrected(MAX), IDENTIFY_RANGE[1]);
        let mut last = f32::NEG_INFINITY;
        for i in 0..=1000 {
            let k = IDENTIFY_RANGE[0] + (MAX - IDENTIFY_RANGE[0]) * i as f32 / 1000.0;
            let c = corrected(k);
            assert!(c >= last && c <= IDENTIFY_RANGE[1], "{k} -> {c}");
            last = c;
        }
    }

    #[cfg(feature = "observer")]
    #[test]
    fn only_a_torque_swinging_to_a_limit_from_the_other_side_at_rest_counts_as_a_ring() {
        let limit = 10.0;
        // From `last` applied, with the moving regulator's weight `w`, the command `u`:
        // what it adds to the gauge's residual, and whether it marks the move.
        let tick = |w: f32, last: f32, u: f32| {
            let mut law = LawState::default();
            law.lqg.move_weight = w;
            // At rest: no feedforward, the torque applied all feedback.
            law.lqg.applied_nm = last;
            law.lqg.feedback_nm = last;
            let out = lqg::applied(&mut law, 0.0, -u, limit);
            assert!(out.is_finite());
            (law.lqg.residual_strain, law.lqg.rang, law.lqg.applied_nm)
        };
        // At rest (the moving regulator fading): from the other side of zero past the limit,
        // both ways.
        assert_eq!(tick(0.5, -limit, 1000.0), (RING_STEP, true, limit));
        assert_eq!(tick(0.0, 0.1, -1000.0), (RING_STEP, true, -limit));
        // Not while the reference moves: a move may ask for the limit, and that is the
        // planner's and the feedback's business.
        assert_eq!(tick(1.0, -limit, 1000.0), (0.0, false, limit));
        // Not at one limit on and on (a blocked hub, a load), nor a swing within the limit.
        assert_eq!(tick(0.5, limit, 1000.0), (0.0, false, limit));
        assert_eq!(
            tick(0.5, -limit, limit / FEEDBACK_LOWPASS_ALPHA - limit).0,
            0.0
        );
        // From just below zero the low-pass reaches the limit only on a command of at least
        // `limit / alpha` (64 N m): a jump no move or hold of the shipped laws asks for.
        assert!(!tick(0.5, -1e-3, 63.0).1);
        assert!(tick(0.5, -1e-3, 65.0).1);
        // The residual falls by `1 / RESIDUAL_TICKS` a tick: one such tick stays under the
        // monitor's bound, three on end pass it.
        let (bound, keep) = (
            crate::controller::GAUGE_RESIDUAL,
            1.0 - 1.0 / lqg::RESIDUAL_TICKS,
        );
        assert!(RING_STEP < bound);
        assert!(RING_STEP * (1.0 + keep + keep * keep) > bound);
    }

    #[test]
    fn values_and_settings_round_trip_for_every_law() {
        // Each gain set to its index + 1, by the spec's names: `values` reads them back in
        // the spec's order and `from_values` rebuilds the same law.
        for &kind in LawKind::ALL {
            let n = kind.gain_names().len();
            let values: [f32; MAX_GAINS] =
                core::array::from_fn(|i| if i < n { (i + 1) as f32 } else { 0.0 });
            let settings = Settings {
                switching: Switching::Sat,
                model_terms: true,
            };
            let law = Law::from_values(kind, values, settings);
            assert_eq!(law.kind(), kind);
            assert_eq!(law.values(), values, "{kind}");
            assert_eq!(law.settings(), settings.of(kind), "{kind}");
            assert_eq!(
                Law::from_values(kind, law.values(), law.settings()),
                law,
                "{kind}"
            );
            // The start gains obey their own law's signs.
            assert_eq!(Law::start(kind).kind(), kind);
            assert_eq!(Law::start(kind).check(), Ok(()), "{kind}");
        }
    }

    #[test]
    fn a_named_gain_is_the_field_of_that_name() {
        // By name, not position: smc-i's `c` is its fifth spec, and its field.
        let g = SmcIGains {
            w: 1.0,
            wi: 2.0,
            a: 3.0,
            beta: 4.0,
            c: 5.0,
            switching: Switching::Tanh,
        };
        let i = LawKind::SmcI.gain_index("c").unwrap();
        assert_eq!(Law::from(g).values()[i], 5.0);
        let i = LawKind::SmcStrain.gain_index("beta").unwrap();
        assert_eq!(Law::from(StrainSmcGains::START).values()[i], 0.1);
    }

    pub(crate) fn model() -> ModalModel<3> {
        ModalModel::try_build(&Beam::try_build(BeamParams::aluminium()).unwrap()).unwrap()
    }

    /// Built for one law (the board's `only(its law)`), that law builds and every other is
    /// refused by name; built for every law, every law builds.
    #[test]
    fn a_drive_built_for_one_law_refuses_the_others() {
        let point = PlantPoint::of(&model());
        for &one in LawKind::ALL.iter().filter(|k| !k.has_observer()) {
            for &kind in LawKind::ALL {
                let built = match one {
                    LawKind::Pd => ControlLaw::try_build_in::<{ only(LawKind::Pd) }>,
                    LawKind::Smc => ControlLaw::try_build_in::<{ only(LawKind::Smc) }>,
                    LawKind::SmcStrain => ControlLaw::try_build_in::<{ only(LawKind::SmcStrain) }>,
                    LawKind::PdFf => ControlLaw::try_build_in::<{ only(LawKind::PdFf) }>,
                    _ => ControlLaw::try_build_in::<{ only(LawKind::SmcI) }>,
                }(Law::start(kind), point);
                if kind == one {
                    assert!(built.is_ok(), "{kind}: {built:?}");
                } else {
                    let e = built.unwrap_err();
                    assert_eq!((e.field, e.kind), (kind.name(), ParamErrorKind::NotBuiltIn));
                }
            }
        }
        for &kind in LawKind::ALL.iter().filter(|k| !k.has_observer()) {
            assert!(holds(ALL_LAWS, kind));
            assert!(
                ControlLaw::try_build(Law::start(kind), point).is_ok(),
                "{kind}"
            );
        }
    }

    /// Built without the tanh switching function (a board none of whose rows switches by
    /// it), a law that asks for tanh is refused by the function's name, the same law with
    /// `sat` builds, and it gives the very torque the build with every switching function
    /// gives; the laws without a switching function carry tanh as an unused default and
    /// build.
    #[test]
    fn a_drive_built_without_tanh_refuses_it_and_runs_the_rest_alike() {
        const SET: LawSet = without_tanh(only(LawKind::Smc));
        let point = PlantPoint::of(&model());
        let tanh = Law::Smc(GAINS);
        assert!(tanh.switches_by_tanh());
        let e = ControlLaw::try_build_in::<SET>(tanh, point).unwrap_err();
        assert_eq!((e.field, e.kind), ("tanh", ParamErrorKind::NotBuiltIn));
        let sat = Law::Smc(SmcGains {
            switching: Switching::Sat,
            ..GAINS
        });
        let without = ControlLaw::try_build_in::<SET>(sat, point).unwrap();
        let with = ControlLaw::try_build_in::<{ only(LawKind::Smc) }>(sat, point).unwrap();
        let x = Estimate {
            theta: 0.3,
            omega: -1.2,
            strain: 2e-4,
            ..Estimate::default()
        };
        let r = RefPoint {
            pos: 0.5,
            vel: 2.0,
            acc: -30.0,
        };
        let torque = |law: &ControlLaw, laws_hold_tanh: bool| {
            let mut state = LawState::default();
            if laws_hold_tanh {
                law.torque_nm_in::<{ only(LawKind::Smc) }>(&x, &r, &mut state, 1e-3)
            } else {
                law.torque_nm_in::<SET>(&x, &r, &mut state, 1e-3)
            }
        };
        assert_eq!(
            torque(&without, false).to_bits(),
            torque(&with, true).to_bits()
        );
        assert!(torque(&with, true) != 0.0);
        for kind in [LawKind::Pd, LawKind::PdFf] {
            assert!(!Law::start(kind).switches_by_tanh());
            let set = without_tanh(ALL_LAWS);
            assert!(ControlLaw::try_build_in::<{ without_tanh(ALL_LAWS) }>(
                Law::start(kind),
                point
            )
            .is_ok());
            assert!(holds(set, kind));
        }
    }

    pub(super) const GAINS: SmcGains = SmcGains {
        w: 20.0,
        a: 5.0,
        beta: 0.5,
        switching: Switching::Tanh,
    };

    pub(super) const fn strain(c: f32) -> Law {
        Law::SmcStrain(StrainSmcGains {
            w: GAINS.w,
            a: GAINS.a,
            beta: GAINS.beta,
            c,
            switching: GAINS.switching,
            model_terms: false,
        })
    }

    #[test]
    fn gains_are_validated_with_the_field_named() {
        let m = model();
        let err = |law| ControlLaw::try_build(law, &m).unwrap_err();
        assert_eq!(err(Law::Smc(SmcGains { w: 0.0, ..GAINS })).field, "w");
        assert_eq!(
            err(Law::Smc(SmcGains {
                beta: f32::NAN,
                ..GAINS
            }))
            .kind,
            ParamErrorKind::NonFinite
        );
        assert_eq!(err(Law::Pd(PdGains { kp: -1.0, kd: 1.0 })).field, "kp");
        // A blend so large that the surface loses its control direction is rejected.
        let gamma_sign = strain_coupling(&m).signum();
        assert_eq!(err(strain(gamma_sign * 1e6)).field, "c");
    }
}
