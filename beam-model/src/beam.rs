//! Physical parameters of the slewing beam, the two presets, and their validation.
//!
//! [`BeamParams`] is plain data a user may edit; [`Beam::try_build`] validates it once and is
//! the only way to obtain a [`Beam`], so everything downstream (modal model, controller, plant)
//! may rely on finite, positive, in-range values.

/// Young's modulus of aluminium used by the `aluminium` preset, Pa.
pub const ALUMINIUM_E_PA: f64 = 69.0e9;

pub use beam_kinds::Preset;
use core::fmt;

/// Raw physical parameters (SI units). Validate with [`Beam::try_build`].
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize),
    serde(deny_unknown_fields)
)]
pub struct BeamParams {
    /// Beam length L, m.
    pub length_m: f64,
    /// Beam width w, m.
    pub width_m: f64,
    /// Beam thickness t, m (sets the strain per curvature, t/2).
    pub thickness_m: f64,
    /// Hub radius r, m: the beam is clamped at this distance from the axis.
    pub hub_radius_m: f64,
    /// Material density, kg/m^3.
    pub density_kg_m3: f64,
    /// Flexural rigidity EI, N m^2.
    pub ei_nm2: f64,
    /// Motor plus hub inertia Jm, kg m^2.
    pub jm_kgm2: f64,
    /// Viscous hub friction b, N m s/rad.
    pub viscous_nms: f64,
    /// Coulomb hub friction, N m: the mean of the two directions.
    pub coulomb_nm: f64,
    /// How Coulomb friction differs by direction, N m: half the difference. Turning
    /// positive the hub meets `coulomb_nm + coulomb_asym_nm`, turning negative
    /// `coulomb_nm - coulomb_asym_nm` (a gearbox or seal that drags more one way). At most
    /// `coulomb_nm` either way; 0 in the presets and in files that do not give it.
    #[cfg_attr(feature = "serde", serde(default))]
    pub coulomb_asym_nm: f64,
    /// Tip (payload) mass Mt, kg.
    pub tip_mass_kg: f64,
    /// Modal damping ratio zeta, the same for every mode.
    pub damping_ratio: f64,
    /// Position of the root strain gauge along the beam, m from the clamp.
    pub root_gauge_m: f64,
    /// Position of the mid-span strain gauge, m from the clamp.
    pub mid_gauge_m: f64,
    /// Drive torque limit, N m (symmetric).
    pub torque_limit_nm: f64,
}

impl BeamParams {
    /// The parameters of a named preset.
    pub fn preset(preset: Preset) -> Self {
        match preset {
            Preset::Table1 => Self::table1(),
            Preset::Aluminium => Self::aluminium(),
        }
    }

    /// The paper's Table 1 as printed.
    pub const fn table1() -> Self {
        Self {
            length_m: 0.4842,
            width_m: 0.0762,
            thickness_m: 0.001574,
            hub_radius_m: 0.0889,
            density_kg_m3: 2700.0,
            ei_nm2: 0.176,
            jm_kgm2: 6.92e-3,
            viscous_nms: 1.37e-4,
            coulomb_nm: 0.0,
            coulomb_asym_nm: 0.0,
            tip_mass_kg: 0.0,
            damping_ratio: 0.01,
            root_gauge_m: 0.0,
            mid_gauge_m: 0.4842 / 2.0,
            torque_limit_nm: crate::DRIVE_TORQUE_LIMIT_NM as f64,
        }
    }

    /// Table 1 with the flexural rigidity of an aluminium strip of the same section.
    pub fn aluminium() -> Self {
        let p = Self::table1();
        Self {
            ei_nm2: ALUMINIUM_E_PA * p.width_m * p.thickness_m * p.thickness_m * p.thickness_m
                / 12.0,
            ..p
        }
    }

    /// Mass per unit length rho, kg/m.
    pub fn rho_kg_m(&self) -> f64 {
        self.density_kg_m3 * self.width_m * self.thickness_m
    }

    /// The root gauge's strain per unit hub acceleration (rad/s^2) of the beam bent
    /// statically by it, from the root moment alone (no modes): each element at `r + x`
    /// from the axis carries `rho (r + x)` of inertial load per metre and the payload
    /// `Mt (r + L)`; the moment they make at the gauge, over `EI`, is the curvature there,
    /// and half the thickness times it the strain. Its magnitude: the modal models' sign is
    /// theirs.
    pub fn static_root_strain_per_acc(&self) -> f64 {
        let (r, l, g) = (self.hub_radius_m, self.length_m, self.root_gauge_m);
        // int_g^L (r + x)(x - g) dx, in closed form.
        let f = |x: f64| r * (x * x / 2.0 - g * x) + x * x * x / 3.0 - g * x * x / 2.0;
        let moment = self.rho_kg_m() * (f(l) - f(g)) + self.tip_mass_kg * (r + l) * (l - g);
        0.5 * self.thickness_m * moment / self.ei_nm2
    }
}

/// Validated beam parameters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Beam {
    params: BeamParams,
}

impl Beam {
    /// Validates `params`: every value finite, geometry and inertia positive, losses and tip
    /// mass non-negative, damping ratio below 1, gauges on the beam.
    pub fn try_build(params: BeamParams) -> Result<Beam, ParamError> {
        let p = &params;
        let positive = [
            ("length_m", p.length_m),
            ("width_m", p.width_m),
            ("thickness_m", p.thickness_m),
            ("density_kg_m3", p.density_kg_m3),
            ("ei_nm2", p.ei_nm2),
            ("jm_kgm2", p.jm_kgm2),
            ("torque_limit_nm", p.torque_limit_nm),
        ];
        let non_negative = [
            ("hub_radius_m", p.hub_radius_m),
            ("viscous_nms", p.viscous_nms),
            ("coulomb_nm", p.coulomb_nm),
            ("tip_mass_kg", p.tip_mass_kg),
            ("damping_ratio", p.damping_ratio),
            ("root_gauge_m", p.root_gauge_m),
            ("mid_gauge_m", p.mid_gauge_m),
        ];
        for (field, v) in positive.iter().chain(non_negative.iter()) {
            if !v.is_finite() {
                return Err(ParamError {
                    field,
                    kind: ParamErrorKind::NonFinite,
                });
            }
        }
        for (field, v) in positive {
            if v <= 0.0 {
                return Err(ParamError {
                    field,
                    kind: ParamErrorKind::NotPositive,
                });
            }
        }
        for (field, v) in non_negative {
            if v < 0.0 {
                return Err(ParamError {
                    field,
                    kind: ParamErrorKind::Negative,
                });
            }
        }
        let out_of_range = |field| {
            Err(ParamError {
                field,
                kind: ParamErrorKind::OutOfRange,
            })
        };
        if p.damping_ratio >= 1.0 {
            return out_of_range("damping_ratio");
        }
        // Friction opposes motion in both directions.
        if !p.coulomb_asym_nm.is_finite() {
            return Err(ParamError {
                field: "coulomb_asym_nm",
                kind: ParamErrorKind::NonFinite,
            });
        }
        if p.coulomb_asym_nm.abs() > p.coulomb_nm {
            return out_of_range("coulomb_asym_nm");
        }
        // The strain gauges must sit on the beam.
        if p.root_gauge_m > p.length_m {
            return out_of_range("root_gauge_m");
        }
        if p.mid_gauge_m > p.length_m {
            return out_of_range("mid_gauge_m");
        }
        // A thin beam: Euler-Bernoulli needs thickness well below length.
        if p.thickness_m * 10.0 > p.length_m || p.width_m > p.length_m {
            return out_of_range("thickness_m");
        }
        Ok(Beam { params })
    }

    /// The validated parameters.
    pub fn params(&self) -> &BeamParams {
        &self.params
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn presets_validate_and_aluminium_is_ten_times_stiffer() {
        for &p in Preset::ALL {
            assert!(Beam::try_build(BeamParams::preset(p)).is_ok());
        }
        // docs/design.md, section 2: aluminium with Table 1's section gives EI about 1.71 N m^2.
        let ei = BeamParams::aluminium().ei_nm2;
        assert!((ei - 1.71).abs() < 0.01, "EI {ei}");
    }

    #[test]
    fn errors_name_the_field() {
        let bad = BeamParams {
            ei_nm2: f64::NAN,
            ..BeamParams::table1()
        };
        assert_eq!(
            Beam::try_build(bad),
            Err(ParamError {
                field: "ei_nm2",
                kind: ParamErrorKind::NonFinite
            })
        );
        let bad = BeamParams {
            tip_mass_kg: -0.1,
            ..BeamParams::table1()
        };
        assert_eq!(Beam::try_build(bad).unwrap_err().field, "tip_mass_kg");
        let bad = BeamParams {
            root_gauge_m: 1.0,
            ..BeamParams::table1()
        };
        assert_eq!(
            Beam::try_build(bad).unwrap_err().kind,
            ParamErrorKind::OutOfRange
        );
        let bad = BeamParams {
            jm_kgm2: 0.0,
            ..BeamParams::table1()
        };
        assert_eq!(
            Beam::try_build(bad).unwrap_err().kind,
            ParamErrorKind::NotPositive
        );
    }
}

/// What is wrong with a parameter.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ParamErrorKind {
    /// NaN or infinite.
    NonFinite,
    /// Must be strictly positive.
    NotPositive,
    /// Must be zero or positive.
    Negative,
    /// Outside its documented range.
    OutOfRange,
    /// Needs the whole modal model and its instruments to be designed (an observer law built
    /// on a plant point or a bare model).
    NeedsModel,
    /// No stable design exists for it (a Riccati equation did not converge).
    NoDesign,
    /// Not in this build: a drive built for one law (its gain table's `[drive]` law) holds
    /// no other law's code.
    NotBuiltIn,
}

/// A rejected value: which field and why. The field is named as in the structure being
/// validated: a [`BeamParams`] field, a gain of a control law
/// (`w`, `kp`, `c`, ...) or a controller setting (`torque_limit_nm`, `adc.bits`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ParamError {
    /// The field's name.
    pub field: &'static str,
    /// The reason.
    pub kind: ParamErrorKind,
}

impl fmt::Display for ParamError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let why = match self.kind {
            ParamErrorKind::NonFinite => "must be finite",
            ParamErrorKind::NotPositive => "must be > 0",
            ParamErrorKind::Negative => "must be >= 0",
            ParamErrorKind::OutOfRange => "is out of range",
            ParamErrorKind::NeedsModel => {
                "needs a modal model and the instruments that read it to design on"
            }
            ParamErrorKind::NoDesign => "has no stable design",
            ParamErrorKind::NotBuiltIn => "is not built into this drive",
        };
        write!(f, "`{}` {}", self.field, why)
    }
}

impl core::error::Error for ParamError {}
