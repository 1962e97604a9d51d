//! The names a user chooses from, written once: the control-law kind (with each law's gains
//! and settings as a user sees them), the switching function, the shaper and the parameter
//! preset.
//!
//! Each is a small `Copy` enum with [`name`](LawKind::name) (the spelling on the command line,
//! in `gains.toml` and in JSON), [`FromStr`], `ALL` (for listings and
//! value parsers) and a one-line `help`. With the `serde` feature the same names are the
//! serialised form in text formats (TOML, JSON); binary formats (postcard) use the variant
//! index. Everything else in the workspace (model-core's laws and gain schedule, the gain
//! table, the optimiser, the CLI, the firmware) takes these types, so a misspelt kind is a
//! compile error, and a new variant makes the compiler point at every `match` that must learn
//! it.
//!
//! `no_std`, no allocation: model-core and the firmware use it, and so does gain-table, which
//! model-core's build script runs.
#![no_std]
#![forbid(unsafe_code)]

use core::fmt;
use core::str::FromStr;

/// Defines a named enum: variants with their names and help lines, `name`, `help`, `ALL`,
/// `FromStr`, `Display`, and (with features) serde and defmt, all from one list.
macro_rules! named_enum {
    (
        $(#[$meta:meta])*
        pub enum $ty:ident ($what:literal) {
            $( $(#[$vmeta:meta])* $variant:ident = $name:literal, $help:literal; )+
        }
    ) => {
        $(#[$meta])*
        #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
        #[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
        #[cfg_attr(feature = "defmt", derive(defmt::Format))]
        pub enum $ty {
            $(
                $(#[$vmeta])*
                #[cfg_attr(feature = "serde", serde(rename = $name))]
                $variant,
            )+
        }

        impl $ty {
            /// Every variant, in declaration order.
            pub const ALL: &'static [$ty] = &[$($ty::$variant),+];
            /// Every variant's name, in declaration order.
            pub const NAMES: &'static [&'static str] = &[$($name),+];

            /// The name on the command line, in tables and in JSON.
            pub const fn name(self) -> &'static str {
                match self {
                    $($ty::$variant => $name,)+
                }
            }

            /// A one-line description, for `--help` and listings.
            pub const fn help(self) -> &'static str {
                match self {
                    $($ty::$variant => $help,)+
                }
            }
        }

        impl FromStr for $ty {
            type Err = UnknownName;

            fn from_str(s: &str) -> Result<Self, UnknownName> {
                match s {
                    $($name => Ok($ty::$variant),)+
                    _ => Err(UnknownName { what: $what, expected: Self::NAMES }),
                }
            }
        }

        impl fmt::Display for $ty {
            fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                f.write_str(self.name())
            }
        }
    };
}

named_enum! {
    /// Which control law runs. Each kind's gains (names, units, sign rules, the optimiser's
    /// default ranges) are defined once, in [`LawKind::gains`]; its gain type and the torque
    /// it computes are in model-core's `law` module.
    pub enum LawKind ("control law") {
        /// The PD baseline: `tau = Kp e + Kd e'`.
        Pd = "pd", "PD baseline";
        /// The paper's sliding-mode controller on the hub angle.
        Smc = "smc", "the paper's SMC on the hub angle";
        /// The sliding-mode controller on the blended output `theta + c * root strain`.
        SmcStrain = "smc-strain", "SMC on theta + c * root strain";
        /// Rigid-body feedforward (the whole hub, beam and payload inertia times the reference
        /// acceleration) plus PD: the practical peer, usually run with a shaped reference.
        PdFf = "pd-ff", "rigid-body feedforward plus PD (the practical peer)";
        /// Integral sliding mode with rigid-body feedforward: continuous, and it rejects a
        /// constant load up to the switching gain times Jeff.
        SmcI = "smc-i", "integral sliding mode with rigid-body feedforward";
        /// LQR with integral action on a steady-state Kalman observer of the hub and the
        /// flexible modes (encoder, root strain and torque in), with rigid-body feedforward:
        /// the torque sees the modes, so the loop damps the beam.
        Lqg = "lqg", "LQR + integral on a Kalman modal observer, with feedforward";
        /// The paper's sliding mode carried to the full state: the surface is the LQR's
        /// combination of the observed hub and flexible modes, on the LQG law's observer and
        /// feedforward, with the switching term along it.
        SmcModal = "smc-modal", "SMC on the observed hub and modes (full-state surface)";
    }
}

impl LawKind {
    /// The law a drive runs when its gain table's `[drive]` names none: the paper's SMC.
    pub const DEFAULT_DRIVE: LawKind = LawKind::Smc;
}

named_enum! {
    /// The input shaper applied to a move's reference (docs/design.md, section 3): a train of
    /// impulses the base move is convolved with, so that it does not excite a mode.
    #[derive(Default)]
    pub enum ShaperKind ("shaper") {
        /// No shaping: the base move as planned.
        #[default]
        None = "none", "no shaping";
        /// Zero vibration: two impulses, half a damped period apart.
        Zv = "zv", "zero vibration: 2 impulses over half a period";
        /// Zero vibration and derivative: three impulses over one damped period, robust to
        /// frequency error.
        Zvd = "zvd", "zero vibration and derivative: 3 impulses over one period";
        /// Extra-insensitive: three impulses over one period, residual vibration at most the
        /// tolerance over a wider band.
        Ei = "ei", "extra-insensitive: 3 impulses, vibration within a tolerance over a wide band";
    }
}

named_enum! {
    /// The boundary-layer switching function f in the SMC's `A f(beta s)`.
    #[derive(Default)]
    pub enum Switching ("switching function") {
        /// Smooth bounded sign, tanh (the default: no chatter).
        #[default]
        Tanh = "tanh", "smooth, bounded sign";
        /// Linear boundary layer, clamp(x, -1, 1).
        Sat = "sat", "linear boundary layer";
        /// Ideal relay, sign(x) (chatters; for comparison).
        Sign = "sign", "ideal relay";
    }
}

named_enum! {
    /// The named beam parameter sets (model-core's `BeamParams::preset` gives the numbers).
    pub enum Preset ("preset") {
        /// The paper's Table 1 as printed (EI = 0.176 N m^2, ten times too soft for the strip).
        Table1 = "table1", "the paper's Table 1 as printed (EI 0.176 N m^2; the slew breaks the model)";
        /// Table 1's geometry with EI = E w t^3 / 12 for aluminium, E = 69 GPa.
        Aluminium = "aluminium", "Table 1's aluminium strip with EI = E w t^3 / 12 (about 1.71 N m^2)";
    }
}

impl Switching {
    /// f(x).
    #[inline]
    pub fn apply(self, x: f32) -> f32 {
        match self {
            Switching::Tanh => libm::tanhf(x),
            Switching::Sat => x.clamp(-1.0, 1.0),
            Switching::Sign => {
                if x > 0.0 {
                    1.0
                } else if x < 0.0 {
                    -1.0
                } else {
                    0.0
                }
            }
        }
    }
}

/// How a gain may be signed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Sign {
    /// Strictly positive.
    Positive,
    /// Zero or positive.
    NonNegative,
    /// Any finite value.
    Any,
}

/// Where the optimiser searches a gain by default.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Search {
    /// Log-uniformly between the two bounds.
    Log(f64, f64),
    /// Linearly over the strain blends the plant can take (`1 - c gamma` kept well above
    /// its limit): the bounds come from the model.
    Blend,
}

/// One gain of a law: its name (in `gains.toml`, on the command line, in JSON), its unit,
/// its sign rule and where the optimiser searches it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GainSpec {
    /// The gain's name.
    pub name: &'static str,
    /// Its unit.
    pub unit: &'static str,
    /// Its sign rule.
    pub sign: Sign,
    /// The optimiser's default range.
    pub search: Search,
    /// The value taken when a row leaves the gain out (`None`: it must be given).
    pub default: Option<f64>,
}

/// Why a gain's value is refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GainRule {
    /// NaN or infinite.
    NonFinite,
    /// Must be > 0.
    NotPositive,
    /// Must be >= 0.
    Negative,
}

impl GainSpec {
    /// Checks `value` against the sign rule (and that it is finite).
    pub fn check(&self, value: f64) -> Result<(), GainRule> {
        self.sign.check(value)
    }
}

impl Sign {
    /// Checks `value` against the rule (and that it is finite).
    pub fn check(self, value: f64) -> Result<(), GainRule> {
        if !value.is_finite() {
            return Err(GainRule::NonFinite);
        }
        match self {
            Sign::Positive if !(value > 0.0) => Err(GainRule::NotPositive),
            Sign::NonNegative if value < 0.0 => Err(GainRule::Negative),
            _ => Ok(()),
        }
    }
}

/// A law's setting that is not a number: it is not interpolated between payloads, so every
/// row of a law must agree on it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Setting {
    /// The switching function f of a sliding-mode law (`switching`).
    Switching,
    /// The strain law's model terms (`model_terms`).
    ModelTerms,
}

impl Setting {
    /// The setting's name in `gains.toml` and in JSON.
    pub const fn name(self) -> &'static str {
        match self {
            Setting::Switching => "switching",
            Setting::ModelTerms => "model_terms",
        }
    }
}

/// The values of every [`Setting`]. A law reads those it has ([`LawKind::settings`]); the
/// others stay at their defaults (tanh, no model terms).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Settings {
    /// The switching function.
    pub switching: Switching,
    /// Keep the strain law's model terms.
    pub model_terms: bool,
}

impl Settings {
    /// Every setting at its default: tanh, no model terms (`const`, unlike `Default`).
    pub const DEFAULT: Settings = Settings {
        switching: Switching::Tanh,
        model_terms: false,
    };

    /// Only the settings law `kind` has; the others at their defaults. Two rows of a law
    /// agree when these agree.
    pub fn of(self, kind: LawKind) -> Settings {
        let has = |s| kind.settings().contains(&s);
        Settings {
            switching: if has(Setting::Switching) {
                self.switching
            } else {
                Switching::default()
            },
            model_terms: has(Setting::ModelTerms) && self.model_terms,
        }
    }
}

/// `None`, or `Some` of the given default.
macro_rules! optional {
    () => {
        None
    };
    ($default:expr) => {
        Some($default)
    };
}

/// Each law's definition as the user sees it, once: its gains (name, unit, sign rule, the
/// optimiser's default range, and a default for a gain that may be left out) in the
/// optimiser's search order, and its non-numeric settings. The macro lays the gains out as
/// parallel lists, so the drive, which checks signs, links the names and the rules but not
/// the units or the ranges. model-core's gain types are checked against these names at
/// compile time.
macro_rules! law_gains {
    ($(
        [$($kind:ident),+] ($($setting:ident),*) => [$(
            ($name:literal, $unit:literal, $sign:ident, $search:expr $(, default $default:expr)?)
        ),+]
    );+ $(;)?) => {
        impl LawKind {
            /// The law's gain names, in the optimiser's search order.
            pub const fn gain_names(self) -> &'static [&'static str] {
                match self { $( $(LawKind::$kind)|+ => &[$($name),+], )+ }
            }

            /// The sign rule of each gain, in [`LawKind::gain_names`]' order.
            pub const fn gain_signs(self) -> &'static [Sign] {
                match self { $( $(LawKind::$kind)|+ => &[$(Sign::$sign),+], )+ }
            }

            /// The unit of each gain, in [`LawKind::gain_names`]' order.
            pub const fn gain_units(self) -> &'static [&'static str] {
                match self { $( $(LawKind::$kind)|+ => &[$($unit),+], )+ }
            }

            /// The optimiser's default range of each gain, in [`LawKind::gain_names`]' order.
            pub const fn gain_search(self) -> &'static [Search] {
                match self { $( $(LawKind::$kind)|+ => &[$($search),+], )+ }
            }

            /// The value of each gain that may be left out of a row, in
            /// [`LawKind::gain_names`]' order (`None`: required).
            pub const fn gain_defaults(self) -> &'static [Option<f64>] {
                match self { $( $(LawKind::$kind)|+ => &[$(optional!($($default)?)),+], )+ }
            }

            /// The law's non-numeric settings.
            pub const fn settings(self) -> &'static [Setting] {
                match self { $( $(LawKind::$kind)|+ => &[$(Setting::$setting),*], )+ }
            }
        }
    };
}

law_gains! {
    [Pd, PdFf] () => [
        ("kp", "N m/rad", NonNegative, Search::Log(0.5, 200.0)),
        ("kd", "N m s/rad", NonNegative, Search::Log(0.01, 20.0))
    ];
    [Smc] (Switching) => [
        ("w", "1/s", Positive, Search::Log(1.0, 200.0)),
        ("a", "rad/s^2", NonNegative, Search::Log(10.0, 5000.0)),
        ("beta", "s/rad", Positive, Search::Log(0.003, 5.0))
    ];
    [SmcStrain] (Switching, ModelTerms) => [
        ("w", "1/s", Positive, Search::Log(1.0, 200.0)),
        ("a", "rad/s^2", NonNegative, Search::Log(10.0, 5000.0)),
        ("beta", "s/rad", Positive, Search::Log(0.003, 5.0)),
        ("c", "rad per unit strain", Any, Search::Blend)
    ];
    [SmcI] (Switching) => [
        ("w", "1/s", Positive, Search::Log(1.0, 200.0)),
        ("wi", "1/s^2", NonNegative, Search::Log(0.1, 10000.0)),
        ("a", "rad/s^2", NonNegative, Search::Log(10.0, 5000.0)),
        ("beta", "s/rad", Positive, Search::Log(0.003, 5.0)),
        ("c", "rad per unit strain", Any, Search::Blend, default 0.0)
    ];
    [Lqg] () => [
        ("kp", "N m/rad", Positive, Search::Log(1.0, 2000.0)),
        ("kd", "N m s/rad", Positive, Search::Log(0.01, 50.0)),
        ("ki", "N m/(rad s)", NonNegative, Search::Log(1.0, 20000.0)),
        ("kq", "(N m)^2/J", NonNegative, Search::Log(1.0, 1e7)),
        ("sigma", "N m", Positive, Search::Log(0.01, 10.0))
    ];
    [SmcModal] (Switching) => [
        ("kp", "N m/rad", Positive, Search::Log(1.0, 2000.0)),
        ("kq", "(N m)^2/J", NonNegative, Search::Log(1.0, 1e7)),
        ("sigma", "N m", Positive, Search::Log(0.01, 10.0)),
        ("a", "rad/s^2", NonNegative, Search::Log(1.0, 5000.0)),
        ("beta", "s/rad", Positive, Search::Log(0.003, 5.0))
    ];
}

/// Most gains a law has: model-core's fixed gain arrays are this long.
pub const MAX_GAINS: usize = 5;

const _: () = {
    let mut i = 0;
    while i < LawKind::ALL.len() {
        assert!(LawKind::ALL[i].gain_names().len() <= MAX_GAINS);
        i += 1;
    }
};

/// True when `a` and `b` hold the same names in the same order (a `const fn`, for the
/// compile-time checks that model-core's gain types follow [`LawKind::gain_names`]).
pub const fn same_names(a: &[&str], b: &[&str]) -> bool {
    if a.len() != b.len() {
        return false;
    }
    let mut i = 0;
    while i < a.len() {
        let (x, y) = (a[i].as_bytes(), b[i].as_bytes());
        if x.len() != y.len() {
            return false;
        }
        let mut j = 0;
        while j < x.len() {
            if x[j] != y[j] {
                return false;
            }
            j += 1;
        }
        i += 1;
    }
    true
}

/// True when `a` and `b` hold the same settings in the same order (`const`, as
/// [`same_names`]).
pub const fn same_settings(a: &[Setting], b: &[Setting]) -> bool {
    if a.len() != b.len() {
        return false;
    }
    let mut i = 0;
    while i < a.len() {
        if a[i] as u8 != b[i] as u8 {
            return false;
        }
        i += 1;
    }
    true
}

impl LawKind {
    /// The law runs on a state observer of the beam's modes (lqg, smc-modal), whose design a
    /// drive carries compiled in, made on the host.
    pub const fn has_observer(self) -> bool {
        matches!(self, LawKind::Lqg | LawKind::SmcModal)
    }

    /// The law's gains, in the optimiser's search order: the one definition of their names,
    /// units, sign rules and default search ranges, which the gain table's validation, the
    /// law's own validation in model-core and the optimiser read.
    pub fn gains(self) -> impl Iterator<Item = GainSpec> {
        let (names, units) = (self.gain_names(), self.gain_units());
        let (signs, search) = (self.gain_signs(), self.gain_search());
        let defaults = self.gain_defaults();
        (0..names.len()).map(move |i| GainSpec {
            name: names[i],
            unit: units[i],
            sign: signs[i],
            search: search[i],
            default: defaults[i],
        })
    }

    /// The spec of the gain `name`, if the law has it.
    pub fn gain(self, name: &str) -> Option<GainSpec> {
        self.gains().find(|g| g.name == name)
    }

    /// Where the gain `name` is in the law's gain list.
    pub fn gain_index(self, name: &str) -> Option<usize> {
        self.gain_names().iter().position(|n| *n == name)
    }

    /// True when the law has the setting `s`.
    pub fn has(self, s: Setting) -> bool {
        self.settings().contains(&s)
    }
}

/// A name that is none of a kind's variants.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct UnknownName {
    /// What was being named ("control law", "preset", ...).
    pub what: &'static str,
    /// The names that would have been accepted.
    pub expected: &'static [&'static str],
}

impl fmt::Display for UnknownName {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "unknown {}; expected one of ", self.what)?;
        for (i, name) in self.expected.iter().enumerate() {
            write!(f, "{}{name}", if i == 0 { "" } else { ", " })?;
        }
        Ok(())
    }
}

impl core::error::Error for UnknownName {}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_law_has_one_spec_per_gain_with_distinct_names_and_sane_ranges() {
        for &k in LawKind::ALL {
            let n = k.gain_names().len();
            assert!(n > 0, "{k}");
            assert_eq!(k.gain_signs().len(), n, "{k}");
            assert_eq!(k.gain_units().len(), n, "{k}");
            assert_eq!(k.gain_search().len(), n, "{k}");
            assert_eq!(k.gain_defaults().len(), n, "{k}");
            for (i, g) in k.gains().enumerate() {
                assert!(
                    k.gain_names()[..i].iter().all(|m| *m != g.name),
                    "{k}: {}",
                    g.name
                );
                assert!(!g.unit.is_empty());
                if let Search::Log(lo, hi) = g.search {
                    assert!(0.0 < lo && lo < hi, "{k}: {}", g.name);
                    // The default range obeys the sign rule.
                    assert_eq!(g.check(lo), Ok(()));
                }
                if let Some(d) = g.default {
                    assert_eq!(g.check(d), Ok(()), "{k}: {}", g.name);
                }
            }
        }
        assert_eq!(Sign::Positive.check(0.0), Err(GainRule::NotPositive));
        assert_eq!(Sign::NonNegative.check(0.0), Ok(()));
        assert_eq!(Sign::NonNegative.check(-1e-9), Err(GainRule::Negative));
        assert_eq!(Sign::Any.check(f64::NAN), Err(GainRule::NonFinite));
    }

    #[test]
    fn every_name_parses_back_to_its_variant() {
        for &k in LawKind::ALL {
            assert_eq!(k.name().parse::<LawKind>(), Ok(k));
        }
        for &s in Switching::ALL {
            assert_eq!(s.name().parse::<Switching>(), Ok(s));
        }
        for &p in Preset::ALL {
            assert_eq!(p.name().parse::<Preset>(), Ok(p));
        }
        for &k in ShaperKind::ALL {
            assert_eq!(k.name().parse::<ShaperKind>(), Ok(k));
        }
        assert_eq!(LawKind::SmcStrain.name(), "smc-strain");
    }

    #[test]
    fn an_unknown_name_lists_the_choices() {
        let e = "lqr".parse::<LawKind>().unwrap_err();
        let mut buf = [0u8; 96];
        let mut w = Buf(&mut buf, 0);
        core::fmt::write(&mut w, format_args!("{e}")).unwrap();
        assert_eq!(
            core::str::from_utf8(&w.0[..w.1]).unwrap(),
            "unknown control law; expected one of pd, smc, smc-strain, pd-ff, smc-i, lqg, smc-modal"
        );
        assert!(
            "Smc".parse::<LawKind>().is_err(),
            "names are case-sensitive"
        );
    }

    #[test]
    fn switching_functions_are_bounded_odd_signs() {
        for &f in Switching::ALL {
            assert_eq!(f.apply(0.0), 0.0);
            assert_eq!(f.apply(1e6), 1.0);
            assert_eq!(f.apply(-1e6), -1.0);
            assert_eq!(f.apply(0.3), -f.apply(-0.3));
        }
        assert_eq!(Switching::Sat.apply(0.25), 0.25);
        assert_eq!(Switching::default(), Switching::Tanh);
    }

    /// A fixed buffer to format into without alloc.
    struct Buf<'a>(&'a mut [u8], usize);
    impl fmt::Write for Buf<'_> {
        fn write_str(&mut self, s: &str) -> fmt::Result {
            let end = self.1 + s.len();
            self.0
                .get_mut(self.1..end)
                .ok_or(fmt::Error)?
                .copy_from_slice(s.as_bytes());
            self.1 = end;
            Ok(())
        }
    }
}
