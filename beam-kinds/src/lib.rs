//! The names a user chooses from, written once: the control-law kind, the switching function
//! and the parameter preset.
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
    /// Which control law runs. Each kind has its own gain type in model-core's `law` module,
    /// its own search bounds in the optimiser and its own row shape in `gains.toml`.
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
    }
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
            "unknown control law; expected one of pd, smc, smc-strain, pd-ff, smc-i"
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
