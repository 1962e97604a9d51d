//! The errors of the beam's parameters and of its model: each names what was wrong,
//! implements `Display` (one line, lower case, no trailing period) and `core::error::Error`,
//! and is `Copy`, so the firmware can keep one without allocating and the host can box it.

use crate::modal::MAX_MODES;
use core::fmt;

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
}

/// A rejected value: which field and why. The field is named as in the structure being
/// validated: a [`BeamParams`](crate::beam::BeamParams) field, a gain of a control law
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
        };
        write!(f, "`{}` {}", self.field, why)
    }
}

/// Why a model could not be built.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ModelError {
    /// The mode count must be 1 to 4.
    UnsupportedModeCount(usize),
    /// A mass matrix came out singular or indefinite (cannot happen for valid parameters).
    NotPositiveDefinite(&'static str),
}

impl fmt::Display for ModelError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ModelError::UnsupportedModeCount(n) => {
                write!(
                    f,
                    "{n} modes requested: the model supports 1 to {MAX_MODES}"
                )
            }
            ModelError::NotPositiveDefinite(what) => write!(f, "{what} is not positive definite"),
        }
    }
}

impl core::error::Error for ParamError {}
impl core::error::Error for ModelError {}
