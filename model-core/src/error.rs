//! Every error model-core returns, in one place: each names what was wrong, implements
//! `Display` (one line, lower case, no trailing period) and `core::error::Error`, and is
//! `Copy`, so the firmware can keep one without allocating and the host can box it.
//!
//! Faults of a running controller are not errors: they are latched
//! [`FaultFlags`](crate::FaultFlags), reported in every [`TorqueCommand`](crate::TorqueCommand).

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
/// validated: a [`BeamParams`](crate::BeamParams) field, a gain of a
/// [`Law`](crate::Law) (`w`, `kp`, `c`, ...) or a
/// [`ControllerSettings`](crate::ControllerSettings) field (`torque_limit_nm`, `adc.bits`).
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

/// Why a spline could not be built.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum SplineError {
    /// At least two knots are needed.
    TooFewKnots,
    /// More knots than the spline's capacity.
    TooManyKnots {
        /// The capacity `K`.
        capacity: usize,
    },
    /// Knot `index` has a NaN or infinite time or position.
    NonFinite {
        /// Offending knot.
        index: usize,
    },
    /// The first knot must be at t = 0 (time counts from the start of the move).
    FirstKnotNotAtZero,
    /// Knot `index` is not later than the knot before it.
    TimesNotIncreasing {
        /// Offending knot.
        index: usize,
    },
}

impl fmt::Display for SplineError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            SplineError::TooFewKnots => write!(f, "a move needs at least two knots"),
            SplineError::TooManyKnots { capacity } => {
                write!(f, "a move holds at most {capacity} knots")
            }
            SplineError::NonFinite { index } => write!(f, "knot {index} is not finite"),
            SplineError::FirstKnotNotAtZero => write!(f, "the first knot must be at t = 0"),
            SplineError::TimesNotIncreasing { index } => {
                write!(f, "knot {index} is not later than the knot before it")
            }
        }
    }
}

/// Why a controller could not be built.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ConfigError {
    /// A setting or gain is invalid.
    Param(ParamError),
}

impl From<ParamError> for ConfigError {
    fn from(e: ParamError) -> Self {
        ConfigError::Param(e)
    }
}

impl fmt::Display for ConfigError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ConfigError::Param(e) => e.fmt(f),
        }
    }
}

/// Why a command was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum CommandError {
    /// A fault is latched: reset first.
    Faulted,
    /// A move is already running.
    Busy,
}

impl core::error::Error for ParamError {}
impl core::error::Error for ModelError {}
impl core::error::Error for SplineError {}
// `ConfigError` displays its cause's message as its own, so it reports no separate source
// (an error chain would print the message twice).
impl core::error::Error for ConfigError {}
impl core::error::Error for CommandError {}

impl fmt::Display for CommandError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            CommandError::Faulted => "a fault is latched: clear it first",
            CommandError::Busy => "a move is running",
        })
    }
}
