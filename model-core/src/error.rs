//! Every error model-core returns, in one place: each names what was wrong, implements
//! `Display` (one line, lower case, no trailing period) and `core::error::Error`, and is
//! `Copy`, so the firmware can keep one without allocating and the host can box it.
//!
//! Faults of a running controller are not errors: they are latched
//! [`FaultFlags`](crate::FaultFlags), reported in every [`TorqueCommand`](crate::TorqueCommand).

pub use beam_model::{ModelError, ParamError, ParamErrorKind};
use core::fmt;

/// Why a shaper cannot be built.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ShaperError {
    /// The frequency is not a positive, finite number.
    Frequency,
    /// The damping ratio is outside [0, 1) (or so large the train has a non-positive impulse).
    Damping,
    /// EI's tolerance is outside (0, 0.5).
    Tolerance,
    /// The shaper is as long as the move or longer, so the base move cannot be shortened.
    TooLong,
    /// The shaped move does not fit the spline's knot capacity.
    Spline(SplineError),
}

impl fmt::Display for ShaperError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ShaperError::Frequency => f.write_str("the shaper frequency must be positive"),
            ShaperError::Damping => f.write_str("the shaper damping ratio must be in [0, 1)"),
            ShaperError::Tolerance => f.write_str("the EI tolerance must be in (0, 0.5)"),
            ShaperError::TooLong => {
                f.write_str("the shaper is as long as the move: it cannot end on time")
            }
            ShaperError::Spline(e) => write!(f, "shaped move: {e}"),
        }
    }
}

impl core::error::Error for ShaperError {}

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
    /// No move is running (nothing to stop).
    NotMoving,
}

/// Why a move was not planned. The drive refuses it and keeps what it was doing.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum PlanError {
    /// The move needs more time than it was given to keep the torque and speed limits.
    TooFast {
        /// The shortest time that keeps them (the same move, uniformly slowed), s.
        needs_s: f32,
    },
    /// A waypoint, the start, or the reference between waypoints leaves the range.
    OutOfRange {
        /// The offending angle, rad.
        rad: f32,
        /// The range's low end, rad.
        min_rad: f32,
        /// The range's high end, rad.
        max_rad: f32,
    },
    /// The move would last longer than the planner accepts.
    TooLong {
        /// The longest move, s ([`crate::planner::MAX_MOVE_S`]).
        max_s: f32,
    },
    /// A move needs at least one waypoint (its target).
    NoWaypoints,
    /// More waypoints than a move holds.
    TooManyWaypoints {
        /// The most a move holds.
        max: usize,
    },
    /// An angle or a time is NaN or infinite.
    NonFinite,
    /// Some waypoints have times and others not, or they have times and the move too.
    MixedTimes,
    /// Waypoint times (or the move's time) are not positive and increasing by at least a
    /// tick (1 ms).
    TimesNotIncreasing,
    /// The limits themselves are unusable (not positive, an empty range, or friction that
    /// uses the whole torque budget).
    BadLimits,
    /// No time within 64 tries kept the limits (not expected: the first try is computed).
    Unplannable,
    /// The spline could not be built.
    Spline(SplineError),
    /// The shaper could not be applied.
    Shaper(ShaperError),
}

impl From<SplineError> for PlanError {
    fn from(e: SplineError) -> Self {
        PlanError::Spline(e)
    }
}

impl From<ShaperError> for PlanError {
    fn from(e: ShaperError) -> Self {
        PlanError::Shaper(e)
    }
}

impl fmt::Display for PlanError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            PlanError::TooFast { needs_s } => write!(
                f,
                "too fast for the torque and speed limits: the move needs {needs_s:.3} s"
            ),
            PlanError::OutOfRange {
                rad,
                min_rad,
                max_rad,
            } => write!(
                f,
                "{:.2} deg is outside the range {:.2} to {:.2} deg",
                rad.to_degrees(),
                min_rad.to_degrees(),
                max_rad.to_degrees()
            ),
            PlanError::TooLong { max_s } => write!(f, "a move lasts at most {max_s} s"),
            PlanError::NoWaypoints => f.write_str("a move needs a target"),
            PlanError::TooManyWaypoints { max } => {
                write!(f, "a move passes through at most {max} waypoints")
            }
            PlanError::NonFinite => f.write_str("an angle or time is not a finite number"),
            PlanError::MixedTimes => f.write_str(
                "give a time for every waypoint or for none (and then at most one for the move)",
            ),
            PlanError::TimesNotIncreasing => {
                f.write_str("waypoint times must be positive and at least 1 ms apart")
            }
            PlanError::BadLimits => f.write_str("the planner's limits are unusable"),
            PlanError::Unplannable => f.write_str("no time keeps the limits"),
            PlanError::Spline(e) => e.fmt(f),
            PlanError::Shaper(e) => e.fmt(f),
        }
    }
}

impl core::error::Error for PlanError {}
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
            CommandError::NotMoving => "no move is running",
        })
    }
}
