//! How many knots each kind of move holds: fixed capacities, so every spline the drive keeps
//! has a size known at compile time. The planner and the shaper both size their moves and
//! scratch space from here.

/// Most waypoints a move passes through (the target included): the wire protocol's limit,
/// defined once there, so a command that decodes is a command the planner takes.
pub use beam_wire::command::MAX_WAYPOINTS;

/// Most impulses a move is shaped by: ZVD and EI have three, and the reference planned
/// exact on a law's reference beam (`planner::exact`, with the `exact` feature) four, two
/// for each of its modes.
pub const MAX_IMPULSES: usize = if cfg!(feature = "exact") { 4 } else { 3 };

/// Knots of an unshaped planned move: the start and the waypoints.
pub const PLAN_KNOTS: usize = MAX_WAYPOINTS + 1;

/// Knots of a planned move's base (unshaped) spline: the start, the waypoints, and room for
/// the one more knot a stop adds (see [`crate::planner::plan_stop`]).
pub const BASE_KNOTS: usize = PLAN_KNOTS + 1;

/// Knots of a shaped planned move: every base knot shifted by each of the shaper's impulses.
pub const SHAPED_PLAN_KNOTS: usize = BASE_KNOTS * MAX_IMPULSES;
