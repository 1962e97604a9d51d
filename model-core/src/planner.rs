//! Moves planned on the drive: rest-to-rest C2 references to a target or through waypoints,
//! within stated torque, speed and range limits, or refused with the reason
//! (docs/design.md, section 3).
//!
//! The planned torque is the rigid-body one, `Mtt |theta_r''| + Coulomb + viscous |theta_r'|`
//! (hub, beam and payload as one body), and the plan may use only `torque_fraction` of the
//! drive's limit: the rest is left to the feedback, which also has to bend the beam and
//! reject loads. The bounds are checked on the finished spline ([`Spline::peaks`], safe
//! upper bounds), after shaping, so a plan that is returned keeps them everywhere.
//!
//! Without a time the planner picks the shortest one. Scaling a spline's knot times by `s`
//! scales its speed by `1/s` and its acceleration by `1/s^2` exactly (the knot velocities
//! and accelerations come from differences of the knots), so the shortest scale follows from
//! the peaks of one trial plan by solving a quadratic; the result is rounded up to whole
//! milliseconds and checked again. Everything here runs outside the 1 kHz tick, with no
//! allocation, in `f32` like the tick: the drive's FPU has no double precision, and `f32`
//! carries a 60 s move's end in whole milliseconds exactly (the spline's knots are `f32`
//! in any case).

pub use crate::error::PlanError;
use crate::law::Law;
use crate::modal::ModalModel;
use crate::plant::PlantPoint;
use crate::shaper::{shape_by, Impulses, Shaper};
use crate::spline::{Peaks, Spline};

pub use crate::knots::{BASE_KNOTS, MAX_WAYPOINTS, PLAN_KNOTS, SHAPED_PLAN_KNOTS};

#[cfg(feature = "exact")]
pub mod exact;
#[cfg(feature = "exact")]
pub use exact::ReferenceBeam;

/// Shortest segment between waypoints, s: one tick.
pub const MIN_SEGMENT_S: f32 = 1e-3;

/// What a planned move must keep to.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Limits {
    /// The drive's torque limit, N m.
    pub torque_limit_nm: f32,
    /// The share of it the planned rigid-body torque may use, in (0, 1].
    pub torque_fraction: f32,
    /// Largest reference speed, rad/s.
    pub max_speed_rad_s: f32,
    /// Lowest hub angle a move may reach, rad.
    pub min_rad: f32,
    /// Highest hub angle a move may reach, rad.
    pub max_rad: f32,
    /// Rigid-body inertia of hub, beam and payload, kg m^2 (`Mtt`).
    pub inertia_kgm2: f32,
    /// Coulomb friction the plan allows for, N m.
    pub coulomb_nm: f32,
    /// Viscous friction the plan allows for, N m s/rad.
    pub viscous_nms: f32,
    /// Shortest segment the planner chooses when it picks the times, s (0, a negative value
    /// or NaN: none; `f32::max` passes over NaN). For a law that bends a reference beam
    /// through the move ([`Law::min_move_periods`]), a move much shorter than the beam's
    /// first period settles later over beams off the model.
    pub min_segment_s: f32,
    /// The root strain the planner's shortest moves are held within, strain (0, a negative
    /// value or NaN: none): the base move's peak acceleration times
    /// [`Limits::strain_per_acc`], the beam bent statically by it. Like
    /// [`Limits::min_segment_s`] it bounds only the times the planner chooses; a move given
    /// its times is the caller's to judge. Set by a law that asks for it
    /// ([`Law::planned_strain`]).
    pub strain_budget: f32,
    /// Root strain per unit hub acceleration of the plant, the beam bent statically
    /// ([`PlantPoint::strain_per_acc`]), strain per rad/s^2.
    pub strain_per_acc: f32,
    /// The law's reference beam, when the shortest moves to a target are planned to leave
    /// it at rest ([`exact`], [`Limits::with_reference_beam`]); `None` plans them as any
    /// other move (the shaped quintic).
    #[cfg(feature = "exact")]
    pub reference_beam: Option<ReferenceBeam>,
}

impl Limits {
    /// Share of the drive's torque a plan uses by default (the feedback keeps the rest).
    pub const DEFAULT_TORQUE_FRACTION: f32 = 0.6;
    /// Default speed limit, rad/s (the paper's slew peaks at 16.8).
    pub const DEFAULT_MAX_SPEED_RAD_S: f32 = 20.0;
    /// Default range, rad: half a turn either side of the zero, the drive's
    /// [`crate::controller::RANGE_RAD`].
    pub const DEFAULT_RANGE_RAD: f32 = crate::controller::RANGE_RAD;

    /// The defaults for the plant (a [`PlantPoint`] or a [`ModalModel`]): its rigid inertia
    /// (with the payload it was built with), friction and torque limit (the drive's 10 N m
    /// for the presets).
    pub fn for_plant(plant: impl Into<PlantPoint>) -> Self {
        let p = plant.into();
        Self {
            torque_limit_nm: p.torque_limit_nm,
            torque_fraction: Self::DEFAULT_TORQUE_FRACTION,
            max_speed_rad_s: Self::DEFAULT_MAX_SPEED_RAD_S,
            min_rad: -Self::DEFAULT_RANGE_RAD,
            max_rad: Self::DEFAULT_RANGE_RAD,
            inertia_kgm2: p.mtt,
            coulomb_nm: p.coulomb_nm,
            viscous_nms: p.viscous_nms,
            min_segment_s: 0.0,
            strain_budget: 0.0,
            strain_per_acc: p.strain_per_acc,
            #[cfg(feature = "exact")]
            reference_beam: None,
        }
    }

    /// [`Limits::for_plant`] with what `law` asks of the planner on that model: the shortest
    /// segment, its [`Law::min_move_periods`] of the first clamped period, and its strain
    /// budget ([`Law::planned_strain`]). (On a modal model: a drive's plant does not carry
    /// the frequency; its table adds the floor, `DriveTable::configure`.)
    pub fn for_law<const N: usize>(model: &ModalModel<N>, law: &Law) -> Self {
        let periods = law.min_move_periods() as f64;
        let hz = model.clamped_hz.first().copied().unwrap_or(0.0);
        Self {
            min_segment_s: if periods > 0.0 && hz > 0.0 {
                (periods / hz) as f32
            } else {
                0.0
            },
            strain_budget: law.planned_strain(),
            ..Self::for_plant(model)
        }
    }

    /// These limits with the reference beam of `law` run every `ts_s`, so that the shortest
    /// moves to a target are planned to leave it at rest ([`exact`]); none for a law
    /// without one (no observer).
    #[cfg(feature = "exact")]
    pub fn with_reference_beam(self, law: &crate::law::ControlLaw, ts_s: f32) -> Self {
        let beam = law
            .observer_design()
            .and_then(|d| ReferenceBeam::of(d, ts_s));
        Self {
            reference_beam: beam,
            ..self
        }
    }

    /// The torque the plan may use, N m.
    pub fn torque_budget_nm(&self) -> f32 {
        self.torque_limit_nm * self.torque_fraction
    }

    fn check(&self) -> Result<(), PlanError> {
        let positive = |x: f32| x.is_finite() && x > 0.0;
        let ok = positive(self.torque_limit_nm)
            && positive(self.torque_fraction)
            && self.torque_fraction <= 1.0
            && positive(self.max_speed_rad_s)
            && self.min_rad.is_finite()
            && self.max_rad.is_finite()
            && self.min_rad < self.max_rad
            && positive(self.inertia_kgm2)
            && self.coulomb_nm.is_finite()
            && self.coulomb_nm >= 0.0
            && self.viscous_nms.is_finite()
            && self.viscous_nms >= 0.0
            && self.coulomb_nm < self.torque_budget_nm();
        if ok {
            Ok(())
        } else {
            Err(PlanError::BadLimits)
        }
    }

    /// The planned torque bound of a move with these peaks, N m.
    pub fn planned_torque_nm(&self, p: &Peaks) -> f32 {
        self.inertia_kgm2 * p.max_abs_acc + self.coulomb_nm + self.viscous_nms * p.max_abs_vel
    }

    /// Whether a move with these peaks keeps the limits.
    pub fn admits(&self, p: &Peaks) -> bool {
        self.planned_torque_nm(p) <= self.torque_budget_nm()
            && p.max_abs_vel <= self.max_speed_rad_s
            && p.min_pos >= self.min_rad - PEAK_TOLERANCE_RAD
            && p.max_pos <= self.max_rad + PEAK_TOLERANCE_RAD
    }

    /// The least time scale `s` (times multiplied by `s`) at which a move with peaks `p` at
    /// scale 1 keeps the torque and speed limits and the strain budget: `I A / s^2 + b V / s
    /// + C <= F`, `V / s <= Vmax` and `g A / s^2 <= E`.
    fn least_scale(&self, p: &Peaks) -> f32 {
        let (a, v) = (p.max_abs_acc, p.max_abs_vel);
        let (i, b) = (self.inertia_kgm2, self.viscous_nms);
        let room = self.torque_budget_nm() - self.coulomb_nm;
        // With x = 1/s: i a x^2 + b v x - room <= 0, so x <= the positive root.
        let qa = i * a;
        let x = if qa > 0.0 {
            (-b * v + beam_model::sqrt::sqrtf(b * b * v * v + 4.0 * qa * room)) / (2.0 * qa)
        } else if b * v > 0.0 {
            room / (b * v)
        } else {
            f32::INFINITY
        };
        let by_torque = 1.0 / x;
        let by_speed = v / self.max_speed_rad_s;
        // (0, a negative budget or NaN: none.)
        let budget = self.strain_budget;
        let by_strain = if budget > 0.0 {
            beam_model::sqrt::sqrtf(a * libm::fabsf(self.strain_per_acc) / budget)
        } else {
            0.0
        };
        by_torque.max(by_speed).max(by_strain)
    }
}

/// A point a move passes through.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Waypoint {
    /// Hub angle, rad.
    pub rad: f32,
    /// When to be there, s after the move starts; `None` lets the planner choose.
    pub at_s: Option<f32>,
}

/// A planned move, ready to swap into the controller whole.
pub type PlannedMove = Spline<SHAPED_PLAN_KNOTS>;

/// A planned move and the unshaped move it was shaped from (which a stop needs).
#[derive(Clone, Debug, PartialEq)]
pub struct Plan {
    /// The reference the controller tracks: `base` shaped.
    pub shaped: PlannedMove,
    /// The move before shaping.
    pub base: Spline<BASE_KNOTS>,
    /// The impulse train it was shaped by (a stop is shaped by it too).
    pub impulses: Impulses,
}

impl Plan {
    fn new(base: Spline<BASE_KNOTS>, shaper: &Shaper) -> Result<Self, PlanError> {
        Self::shaped_by(base, &shaper.impulses()?)
    }

    fn shaped_by(base: Spline<BASE_KNOTS>, impulses: &Impulses) -> Result<Self, PlanError> {
        let shaped = if impulses.iter().count() <= 1 {
            Spline::try_from_states(&base.states::<BASE_KNOTS>())?
        } else {
            shape_by(&base, impulses)?
        };
        Ok(Self {
            shaped,
            base,
            impulses: *impulses,
        })
    }
}

/// The move from `from` to `to`: a minimum-jerk quintic lasting `time_s` (or the shortest
/// the limits allow), shaped by `shaper` (which adds its length).
pub fn plan_move(
    from: f32,
    to: f32,
    time_s: Option<f32>,
    shaper: &Shaper,
    limits: &Limits,
) -> Result<Plan, PlanError> {
    let target = Waypoint {
        rad: to,
        at_s: None,
    };
    plan_through(from, &[target], time_s, shaper, limits)
}

/// The move from `from` through `waypoints` (the last is the target), at rest at both ends,
/// passing the interior waypoints without stopping. Either every waypoint has a time (and
/// `time_s` is `None`) or none does: then the segments share `time_s` (or the shortest time
/// the limits allow) in proportion to each one's shortest rest-to-rest time.
///
pub fn plan_through(
    from: f32,
    waypoints: &[Waypoint],
    time_s: Option<f32>,
    shaper: &Shaper,
    limits: &Limits,
) -> Result<Plan, PlanError> {
    let limits = &checked(from, waypoints, time_s, limits)?;
    // The shortest move to a target, when the limits carry the law's reference beam:
    // planned to leave it at rest (or, if that cannot be done within the limits, as any
    // other move).
    #[cfg(feature = "exact")]
    if let (Some(beam), None, [target]) = (&limits.reference_beam, time_s, waypoints) {
        if target.at_s.is_none() {
            if let Ok(Some(plan)) = exact::plan(from, target.rad, limits, beam) {
                if limits.admits(&plan.shaped.peaks()) {
                    return Ok(plan);
                }
            }
        }
    }
    let timed = waypoints.iter().filter(|w| w.at_s.is_some()).count();
    let given = timed == waypoints.len();
    if (timed != 0 && !given) || (given && time_s.is_some()) {
        return Err(PlanError::MixedTimes);
    }
    // Knot times at scale 1: the given ones, or the shortest rest-to-rest time of each
    // segment.
    // (Indexing by `get`, here and below: no bounds-check panic on the drive's command
    // path; the waypoint count was checked above, so the `None` arms never run.)
    let n = waypoints.len() + 1;
    let mut times = [0.0f32; PLAN_KNOTS];
    let mut positions = [from; PLAN_KNOTS];
    let too_many = PlanError::TooManyWaypoints { max: MAX_WAYPOINTS };
    let (mut t_prev, mut p_prev) = (0.0f32, from);
    for ((w, t), p) in waypoints
        .iter()
        .zip(times.iter_mut().skip(1))
        .zip(positions.iter_mut().skip(1))
    {
        *p = w.rad;
        *t = match w.at_s {
            Some(t) => t,
            None => t_prev + rest_to_rest_time(limits, w.rad - p_prev),
        };
        (t_prev, p_prev) = (*t, *p);
    }
    let end = t_prev;
    let min_gap = times
        .get(..n)
        .ok_or(too_many)?
        .windows(2)
        .map(|w| match w {
            [a, b] => b - a,
            _ => f32::INFINITY,
        })
        .fold(f32::INFINITY, f32::min);
    if !(min_gap >= MIN_SEGMENT_S) {
        return Err(PlanError::TimesNotIncreasing);
    }
    // The plan ending at `end_s`: each knot's time scaled as `t / end * end_s`, so that the
    // last lands on `end_s` exactly (`t * (end_s / end)` can miss it by a step of f32).
    let build = |end_s: f32| -> Result<Plan, PlanError> {
        let mut knots = [(0.0f32, 0.0f32); PLAN_KNOTS];
        for (k, (&t, &p)) in knots.iter_mut().zip(times.iter().zip(positions.iter())) {
            *k = (if end_s == end { t } else { t / end * end_s }, p);
        }
        Plan::new(Spline::try_build(knots.get(..n).ok_or(too_many)?)?, shaper)
    };
    // The scale the limits need, from the unshaped plan at scale 1 (shaping with positive
    // impulses only averages the reference, so it cannot raise the peaks; the check below
    // holds it to that all the same).
    let trial: Spline<PLAN_KNOTS> = {
        let mut knots = [(0.0f32, 0.0f32); PLAN_KNOTS];
        for (k, (&t, &p)) in knots.iter_mut().zip(times.iter().zip(positions.iter())) {
            *k = (t, p);
        }
        Spline::try_build(knots.get(..n).ok_or(too_many)?)?
    };
    let trial = trial.peaks();
    // Positions do not change with the time scale (nor, beyond the ends, with shaping,
    // which averages them): a spline that overshoots the range between waypoints does so
    // at any speed.
    out_of_range(&trial, limits)?;
    // ... and no segment may be shorter than a tick, nor, at the shortest time, than the
    // limits' shortest segment.
    let least = limits
        .least_scale(&trial)
        .max(MIN_SEGMENT_S.max(limits.min_segment_s) / min_gap);
    // The shortest whole-millisecond end time at or above the least scale that passes the
    // check (f32 rounding can cost a millisecond).
    let shortest = || -> Result<(f32, Plan), PlanError> {
        // A margin of 0.1 % keeps the plan off the bound's edge, where f32 rounding of the
        // rebuilt spline could tip it over.
        let mut end_ms = libm::ceilf(least * 1.001 * end * 1000.0).max(1.0);
        for _ in 0..64 {
            // No move may last longer than MAX_MOVE_S, even at its shortest.
            if end_ms > 1000.0 * MAX_MOVE_S {
                return Err(PlanError::TooLong { max_s: MAX_MOVE_S });
            }
            let plan = build(end_ms / 1000.0)?;
            if limits.admits(&plan.shaped.peaks()) {
                return Ok((end_ms / 1000.0, plan));
            }
            end_ms = libm::ceilf(end_ms * 1.01);
        }
        Err(PlanError::Unplannable)
    };
    let end_s = match time_s {
        Some(t) if t > 0.0 => t,
        Some(_) => return Err(PlanError::TimesNotIncreasing),
        None if given => end,
        None => return shortest().map(|(_, plan)| plan),
    };
    if end_s / end * min_gap >= MIN_SEGMENT_S {
        let plan = build(end_s)?;
        let peaks = plan.shaped.peaks();
        if limits.admits(&peaks) {
            return Ok(plan);
        }
        out_of_range(&peaks, limits)?;
    }
    let (needs_s, _) = shortest()?;
    Err(PlanError::TooFast { needs_s })
}

/// The checks of [`plan_through`]'s arguments, in the order its refusals name them, and the
/// limits the move is planned within: a hub outside the range (it coasted there with the
/// torque off) may come back, so the reference may then pass between the start and the
/// range, never further out.
fn checked(
    from: f32,
    waypoints: &[Waypoint],
    time_s: Option<f32>,
    limits: &Limits,
) -> Result<Limits, PlanError> {
    limits.check()?;
    if waypoints.is_empty() {
        return Err(PlanError::NoWaypoints);
    }
    if waypoints.len() > MAX_WAYPOINTS {
        return Err(PlanError::TooManyWaypoints { max: MAX_WAYPOINTS });
    }
    let times_finite = waypoints.iter().all(|w| w.at_s.is_none_or(f32::is_finite))
        && time_s.is_none_or(f32::is_finite);
    if !from.is_finite() || waypoints.iter().any(|w| !w.rad.is_finite()) || !times_finite {
        return Err(PlanError::NonFinite);
    }
    // No move longer than MAX_MOVE_S: a given time or the last waypoint's time here, the
    // shortest time where it is found.
    let last_at = waypoints.last().and_then(|w| w.at_s);
    if time_s.or(last_at).is_some_and(|t| t > MAX_MOVE_S) {
        return Err(PlanError::TooLong { max_s: MAX_MOVE_S });
    }
    for w in waypoints {
        let rad = w.rad;
        if rad < limits.min_rad || rad > limits.max_rad {
            return Err(PlanError::OutOfRange {
                rad,
                min_rad: limits.min_rad,
                max_rad: limits.max_rad,
            });
        }
    }
    // (The bound on the reference's peaks is conservative by up to 1.8e-4 of the move's
    // length: a hundredth of the way back beyond the start covers it.)
    Ok(Limits {
        min_rad: if from < limits.min_rad {
            from - 0.01 * (limits.min_rad - from)
        } else {
            limits.min_rad
        },
        max_rad: if from > limits.max_rad {
            from + 0.01 * (from - limits.max_rad)
        } else {
            limits.max_rad
        },
        ..*limits
    })
}

/// The shortest rest-to-rest quintic over `distance` within the torque and speed limits, s
/// (peak acceleration `10 / sqrt(3) D / T^2`, peak speed `15/8 D / T`); at least 10 ms.
fn rest_to_rest_time(limits: &Limits, distance: f32) -> f32 {
    let d = libm::fabsf(distance);
    let unit = Peaks {
        min_pos: 0.0,
        max_pos: 0.0,
        max_abs_vel: 1.875 * d,
        // 10 / sqrt(3) in f32.
        max_abs_acc: 5.773_503 * d,
    };
    limits
        .least_scale(&unit)
        .max(10.0 * MIN_SEGMENT_S)
        .max(limits.min_segment_s)
}

/// How far the bound on a move's peak position may pass the range's end, rad (0.09 deg).
/// The bound ([`Spline::peaks`]) is conservative by up to about 1.8e-4 of the move's
/// length (5.5e-4 rad for the 180 deg slew, 1.1e-3 rad for -180 to +180 deg), so without it
/// a move that comes to rest exactly on the range's end (+-180 deg) would be refused.
pub const PEAK_TOLERANCE_RAD: f32 = 1.5e-3;

/// The longest move the planner accepts, s (before shaping): a drive is not kept busy
/// for ever by one command. At the default speed limit the whole range takes under a
/// second; a move back into the range from a few turns away, a few seconds.
pub const MAX_MOVE_S: f32 = 60.0;

/// Refuses a move whose reference leaves the range.
fn out_of_range(p: &Peaks, limits: &Limits) -> Result<(), PlanError> {
    let rad = if p.min_pos < limits.min_rad - PEAK_TOLERANCE_RAD {
        p.min_pos
    } else if p.max_pos > limits.max_rad + PEAK_TOLERANCE_RAD {
        p.max_pos
    } else {
        return Ok(());
    };
    Err(PlanError::OutOfRange {
        rad,
        min_rad: limits.min_rad,
        max_rad: limits.max_rad,
    })
}

/// Stops `plan` at `at_s` (time since its start): its base move is kept up to `at_s` and
/// then brought to rest by a quintic from its state there (position, speed, acceleration) to
/// where an even deceleration would end, `pos + vel T / 2`, as short as the torque and speed
/// limits allow; the result is shaped again. The shaped reference is unchanged before
/// `at_s` (every shifted copy of the base is still on its old course there) and C2 through
/// it, and the stop is shaped like the move, so it excites the shaped mode no more than the
/// move would have. The range is not checked: a stop is never refused for it. A plan whose
/// base has ended, or that could not stop short of its target, is returned unchanged (its
/// own end is then the quickest stop).
pub fn plan_stop(plan: &Plan, at_s: f32, limits: &Limits) -> Result<Plan, PlanError> {
    stop_within(plan, at_s, limits, Limits::planned_torque_nm)
}

/// [`plan_stop`], with the stop's torque bounded by `torque(limits, peaks)`.
fn stop_within(
    plan: &Plan,
    at_s: f32,
    limits: &Limits,
    torque: fn(&Limits, &Peaks) -> f32,
) -> Result<Plan, PlanError> {
    limits.check()?;
    if !at_s.is_finite() {
        return Err(PlanError::NonFinite);
    }
    let base = &plan.base;
    if at_s >= base.duration_s() {
        return Ok(plan.clone());
    }
    let at = at_s.max(0.0);
    let r = base.eval(at);
    let decel = (limits.torque_budget_nm() - limits.coulomb_nm) / limits.inertia_kgm2;
    let mut t = (2.0 * libm::fabsf(r.vel) / decel).max(10.0 * MIN_SEGMENT_S);
    let states = base.states::<BASE_KNOTS>();
    let kept = base.knot_times().take_while(|&k| k < at).count();
    while t < 60.0 {
        let t_ms = libm::ceilf(t * 1000.0) / 1000.0;
        let end = r.pos + r.vel * t_ms / 2.0;
        if (end - base.end()) * r.vel > 0.0 {
            // Too late to stop short of the target: the move's own end is the stop.
            return Ok(plan.clone());
        }
        let mut cut = [(0.0f32, 0.0f32, 0.0f32, 0.0f32); BASE_KNOTS + 1];
        // (By `get`: no bounds-check panic on the drive's command path; `kept` is at most
        // the base's knots, and `cut` holds one more.)
        let mut n = 0;
        for (c, s) in cut.iter_mut().zip(states.iter().take(kept)) {
            *c = *s;
            n += 1;
        }
        let mut push = |state| {
            if let Some(c) = cut.get_mut(n) {
                *c = state;
                n += 1;
            }
        };
        if kept == 0 || states.get(kept - 1).is_some_and(|s| s.0 < at) {
            push((at, r.pos, r.vel, r.acc));
        }
        push((at + t_ms, end, 0.0, 0.0));
        // The cut base has at most the base's knots before `at`, `at` and the stop's end.
        let stopped = Spline::<BASE_KNOTS>::try_from_states(cut.get(..n).unwrap_or(&[]))?;
        let p = stopped.peaks();
        if torque(limits, &p) <= limits.torque_budget_nm()
            // (The stop's peak rate is the cut's; its rounding may put it a step above.)
            && p.max_abs_vel <= limits.max_speed_rad_s.max(libm::fabsf(r.vel) * 1.001)
        {
            return Plan::shaped_by(stopped, &plan.impulses);
        }
        t *= 1.1;
    }
    Err(PlanError::Unplannable)
}

/// Brings a hub turning freely (the torque off, after `Disable`) to rest: a reference
/// that starts where the hub is, at its rate, and decelerates evenly as [`plan_stop`] would
/// stop a move there, unshaped (a shaper would hold part of the reference back at the start
/// while the hub runs on). The range is not checked: a hub outside it must be stoppable, and
/// the drive's range fault widens to the brake's end. Nor is the speed limit: the brake never
/// asks for more speed than the hub has.
///
/// The brake decelerates from the start (no acceleration at the rate of the coast), so the
/// friction works with it, not against it: the torque it needs is at most the larger of the
/// inertia's and the friction's, not their sum, which at 25 rad/s would leave no budget at
/// all on a hub with 0.2 N m s/rad of viscous friction.
pub fn plan_brake(from: f32, rate_rad_s: f32, limits: &Limits) -> Result<Plan, PlanError> {
    if !(from.is_finite() && rate_rad_s.is_finite()) {
        return Err(PlanError::NonFinite);
    }
    // A coast that would go on at the rate for the longest move: the stop cuts it at once.
    let coast = [
        (0.0, from, rate_rad_s, 0.0),
        (MAX_MOVE_S, from + rate_rad_s * MAX_MOVE_S, 0.0, 0.0),
    ];
    let coast = Plan::new(Spline::try_from_states(&coast)?, &Shaper::NONE)?;
    stop_within(&coast, 0.0, limits, |l, p| {
        (l.inertia_kgm2 * p.max_abs_acc).max(l.coulomb_nm + l.viscous_nms * p.max_abs_vel)
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::beam::{Beam, BeamParams};
    use crate::modal::ModalModel;
    use crate::shaper::ShaperKind;
    use proptest::prelude::*;

    fn limits() -> Limits {
        let m: ModalModel<3> =
            ModalModel::try_build(&Beam::try_build(BeamParams::aluminium()).unwrap()).unwrap();
        Limits::for_plant(&m)
    }

    const DEG: f32 = core::f32::consts::PI / 180.0;

    #[test]
    fn a_law_that_bends_a_reference_beam_gets_a_floor_on_the_shortest_move() {
        // lqg asks for 0.66 of the first clamped period (5.48 Hz on the aluminium beam); the
        // other laws for none. A 15 deg move's torque-limited time is far below that floor,
        // and with it the shortest plan lasts the floor (to the millisecond).
        let m: ModalModel<3> =
            ModalModel::try_build(&Beam::try_build(BeamParams::aluminium()).unwrap()).unwrap();
        let lqg = Law::Lqg(crate::law::LqgGains {
            kp: 1.0,
            kd: 1.0,
            ki: 0.0,
            kq: 0.0,
            sigma: 1.0,
        });
        let smc = Law::Pd(crate::law::PdGains::BASELINE);
        assert_eq!(Limits::for_law(&m, &smc), limits());
        let floored = Limits::for_law(&m, &lqg);
        let floor = 0.66 / m.clamped_hz[0];
        assert!(
            (floored.min_segment_s as f64 - floor).abs() < 1e-6,
            "{floored:?}"
        );
        let time = |l: &Limits| {
            plan_move(0.0, 15.0 * DEG, None, &Shaper::NONE, l)
                .unwrap()
                .shaped
                .duration_s() as f64
        };
        assert!(time(&limits()) < 0.1);
        let t = time(&floored);
        assert!(
            t >= floor && t < floor + 0.002,
            "{t} s against a floor of {floor} s"
        );
        // A longer move is past the floor already and keeps its torque-limited time.
        let long = |l: &Limits| {
            plan_move(-90.0 * DEG, 90.0 * DEG, None, &Shaper::NONE, l)
                .unwrap()
                .shaped
                .duration_s()
        };
        assert_eq!(long(&floored), long(&limits()));
    }

    #[test]
    fn the_shortest_quintic_uses_the_torque_budget_as_the_closed_form_says() {
        // A quintic over D in T peaks at 10/sqrt(3) D/T^2 and 15/8 D/T; the shortest T
        // solves I a + b v + C = F with both peaks taken together (a safe bound).
        let l = limits();
        let d = 90.0 * DEG;
        let plan = plan_move(0.0, d, None, &Shaper::NONE, &l).unwrap().shaped;
        let t = plan.duration_s() as f64;
        let (i, b, c, f) = (
            l.inertia_kgm2 as f64,
            l.viscous_nms as f64,
            l.coulomb_nm as f64,
            l.torque_budget_nm() as f64,
        );
        let (a, v) = (
            10.0 / 3f64.sqrt() * d as f64 / (t * t),
            1.875 * d as f64 / t,
        );
        assert!(i * a + b * v + c <= f * (1.0 + 1e-6));
        // One millisecond less would break the budget.
        let t1 = t - 1e-3;
        let a1 = 10.0 / 3f64.sqrt() * d as f64 / (t1 * t1);
        assert!(i * a1 + b * 1.875 * d as f64 / t1 + c > f);
        // It is the minimum-jerk quintic: position halfway at half time.
        assert!((plan.eval(plan.duration_s() / 2.0).pos - d / 2.0).abs() < 1e-5);
    }

    #[test]
    fn a_strain_budget_slows_only_the_moves_that_would_pass_it() {
        // The quintic's peak acceleration, 10/sqrt(3) D/T^2, bends the beam statically by
        // `strain_per_acc` times it: with a budget, the shortest T keeps that within the
        // budget and one millisecond less would not. The aluminium beam bends 7.2 ue per
        // rad/s^2 (three modes), so the torque-limited 45 deg move (221 rad/s^2, about
        // 1590 ue) passes a budget of 1000 ue, and the speed-limited 180 deg move (207
        // rad/s^2) keeps within 1600 ue.
        let free = limits();
        let budget = 1.0e-3;
        let held = Limits {
            strain_budget: budget,
            ..free
        };
        let g = held.strain_per_acc.abs() as f64;
        assert!(g > 7.0e-6 && g < 7.4e-6, "{g}");
        let time = |l: &Limits, deg: f32| {
            plan_move(0.0, deg * DEG, None, &Shaper::NONE, l)
                .unwrap()
                .shaped
                .duration_s() as f64
        };
        let d = 45.0 * DEG as f64;
        let strain = |t: f64| g * 10.0 / 3f64.sqrt() * d / (t * t);
        let t = time(&held, 45.0);
        assert!(t > time(&free, 45.0));
        assert!(strain(t) <= budget as f64 * (1.0 + 1e-6), "{}", strain(t));
        assert!(strain(t - 1e-3) > budget as f64, "{}", strain(t - 1e-3));
        let loose = Limits {
            strain_budget: 1.6e-3,
            ..free
        };
        assert_eq!(time(&loose, 180.0), time(&free, 180.0));
        // No budget: 0, a negative value or NaN.
        for none in [0.0, -1.0, f32::NAN] {
            let l = Limits {
                strain_budget: none,
                ..free
            };
            assert_eq!(time(&l, 45.0), time(&free, 45.0));
        }
        // The observer laws, whose observer takes the stiffness identified (and bends soft,
        // heavy beams further for it), ask for 1500 ue; the others for none.
        let m: ModalModel<3> =
            ModalModel::try_build(&Beam::try_build(BeamParams::aluminium()).unwrap()).unwrap();
        for &kind in crate::law::LawKind::ALL {
            let l = Limits::for_law(&m, &Law::start(kind));
            let expect = if kind.has_observer() { 1.5e-3 } else { 0.0 };
            assert_eq!(l.strain_budget, expect, "{kind:?}");
        }
    }

    #[test]
    fn the_papers_slew_fits_the_default_limits_and_a_faster_one_is_refused() {
        let l = limits();
        let paper = plan_move(-90.0 * DEG, 90.0 * DEG, Some(0.35), &Shaper::NONE, &l)
            .unwrap()
            .shaped;
        assert_eq!(paper.duration_s(), 0.35);
        let refused = plan_move(-90.0 * DEG, 90.0 * DEG, Some(0.1), &Shaper::NONE, &l);
        let shortest = plan_move(-90.0 * DEG, 90.0 * DEG, None, &Shaper::NONE, &l)
            .unwrap()
            .shaped
            .duration_s();
        assert_eq!(refused, Err(PlanError::TooFast { needs_s: shortest }));
        assert!(shortest > 0.1 && shortest < 0.35, "{shortest}");
    }

    #[test]
    fn refusals_name_the_reason() {
        let l = limits();
        let none = Shaper::NONE;
        let wp = |rad: f32, at_s: Option<f32>| Waypoint { rad, at_s };
        assert!(matches!(
            plan_move(0.0, 200.0 * DEG, None, &none, &l),
            Err(PlanError::OutOfRange { .. })
        ));
        assert!(matches!(
            plan_move(f32::NAN, 0.1, None, &none, &l),
            Err(PlanError::NonFinite)
        ));
        assert!(matches!(
            plan_move(0.0, 0.1, Some(f32::INFINITY), &none, &l),
            Err(PlanError::NonFinite)
        ));
        assert!(matches!(
            plan_move(0.0, 0.1, Some(-1.0), &none, &l),
            Err(PlanError::TimesNotIncreasing)
        ));
        assert_eq!(
            plan_through(0.0, &[], None, &none, &l),
            Err(PlanError::NoWaypoints)
        );
        assert_eq!(
            plan_through(0.0, &[wp(0.1, None); MAX_WAYPOINTS + 1], None, &none, &l),
            Err(PlanError::TooManyWaypoints { max: MAX_WAYPOINTS })
        );
        assert_eq!(
            plan_through(0.0, &[wp(0.1, Some(0.2)), wp(0.2, None)], None, &none, &l),
            Err(PlanError::MixedTimes)
        );
        assert_eq!(
            plan_through(0.0, &[wp(0.1, Some(0.2))], Some(0.3), &none, &l),
            Err(PlanError::MixedTimes)
        );
        assert_eq!(
            plan_through(
                0.0,
                &[wp(0.1, Some(0.3)), wp(0.2, Some(0.3))],
                None,
                &none,
                &l
            ),
            Err(PlanError::TimesNotIncreasing)
        );
        // A waypoint at the start is a zero-length segment with its own minimum time.
        assert!(plan_through(0.0, &[wp(0.0, None), wp(0.5, None)], None, &none, &l).is_ok());
        let bad = Limits {
            torque_fraction: 0.0,
            ..l
        };
        assert_eq!(
            plan_move(0.0, 0.1, None, &none, &bad),
            Err(PlanError::BadLimits)
        );
        // Fast to 178 deg, then slowly on to 179: the spline carries its speed past 180 deg
        // (at any time scale, so the range is the reason, not the speed).
        let over = [wp(178.0 * DEG, Some(0.2)), wp(179.0 * DEG, Some(1.0))];
        assert!(matches!(
            plan_through(0.0, &over, None, &none, &l),
            Err(PlanError::OutOfRange { .. })
        ));
    }

    #[test]
    fn a_shaped_plan_is_the_impulse_sum_of_the_base_move() {
        let l = limits();
        let zvd = Shaper {
            kind: ShaperKind::Zvd,
            freq_hz: 5.0,
            damping: 0.05,
            tolerance: 0.05,
        };
        let base = plan_move(0.0, 1.0, Some(0.3), &Shaper::NONE, &l)
            .unwrap()
            .shaped;
        let shaped = plan_move(0.0, 1.0, Some(0.3), &zvd, &l).unwrap().shaped;
        let imp = zvd.impulses().unwrap();
        assert!((shaped.duration_s() - (0.3 + imp.duration_s())).abs() < 1e-5);
        for k in 0..=100 {
            let t = k as f32 * shaped.duration_s() / 100.0;
            let sum: f64 = imp
                .iter()
                .map(|(a, ti)| a as f64 * base.eval(t - ti).pos as f64)
                .sum();
            assert!((shaped.eval(t).pos as f64 - sum).abs() < 1e-5, "t {t}");
        }
        // Averaging cannot raise the peaks.
        let (pb, ps) = (base.peaks(), shaped.peaks());
        assert!(ps.max_abs_acc <= pb.max_abs_acc * 1.001);
    }

    #[test]
    fn a_stop_keeps_the_move_up_to_its_time_then_comes_to_rest_within_the_limits() {
        let l = limits();
        let zvd = Shaper {
            kind: ShaperKind::Zvd,
            freq_hz: 4.8,
            damping: 0.07,
            tolerance: 0.05,
        };
        let plan = plan_move(-90.0 * DEG, 90.0 * DEG, None, &zvd, &l).unwrap();
        let at = 0.08;
        let stopped = plan_stop(&plan, at, &l).unwrap();
        // Unchanged before the stop (every shifted copy of the base is on its old course).
        for k in 0..80 {
            let t = k as f32 * 1e-3;
            let (a, b) = (plan.shaped.eval(t), stopped.shaped.eval(t));
            assert!(
                (a.pos - b.pos).abs() < 1e-5 && (a.vel - b.vel).abs() < 1e-3,
                "t {t}"
            );
        }
        // It ends at rest short of the target, inside the limits, and no sooner than the
        // shaper's length after the stop (the stop is shaped too).
        let s = &stopped.shaped;
        assert!(s.end() < 90.0 * DEG && s.end() > -90.0 * DEG, "{}", s.end());
        assert!(l.admits(&s.peaks()) || s.peaks().max_pos > l.max_rad);
        let len = zvd.impulses().unwrap().duration_s();
        assert!(s.duration_s() >= at + len, "{}", s.duration_s());
        assert!(s.duration_s() < plan.shaped.duration_s());
        // Too late to stop short of the target: the move itself is the stop.
        let late = plan_stop(&plan, plan.base.duration_s() * 0.9, &l).unwrap();
        assert_eq!(late, plan);
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(256))]
        /// For any target, waypoints and time, the planner returns a spline within the
        /// limits, checked here by dense sampling independent of `peaks`, or a refusal.
        #[test]
        fn a_plan_keeps_the_limits_or_is_refused(
            from in -3.3f32..3.3,
            targets in proptest::collection::vec(-3.3f32..3.3, 1..=MAX_WAYPOINTS),
            time in proptest::option::of(0.01f32..2.0),
            gaps in proptest::option::of(proptest::collection::vec(0.0005f32..0.6, MAX_WAYPOINTS)),
            fraction in 0.2f32..1.0,
            shaped in any::<bool>(),
        ) {
            let l = Limits { torque_fraction: fraction, ..limits() };
            // With gaps, every waypoint has its time and the move none.
            let mut at = 0.0;
            let waypoints: heapless::Vec<Waypoint, MAX_WAYPOINTS> = targets
                .iter()
                .enumerate()
                .map(|(i, &rad)| Waypoint {
                    rad,
                    at_s: gaps.as_ref().map(|g| {
                        at += g[i];
                        at
                    }),
                })
                .collect();
            let time = if gaps.is_some() { None } else { time };
            let shaper = if shaped {
                Shaper { kind: ShaperKind::Zvd, freq_hz: 4.8, damping: 0.07, tolerance: 0.05 }
            } else {
                Shaper::NONE
            };
            match plan_through(from, &waypoints, time, &shaper, &l) {
                Ok(plan) => {
                    let plan = plan.shaped;
                    // The targets within the range; the reference within it too, or
                    // between the range and a start outside it (a move back into it).
                    let in_range = |x: f32| x >= l.min_rad && x <= l.max_rad;
                    prop_assert!(targets.iter().all(|&t| in_range(t)));
                    let (lo, hi) = (l.min_rad.min(from), l.max_rad.max(from));
                    let in_range = |x: f32| {
                        x >= lo - PEAK_TOLERANCE_RAD && x <= hi + PEAK_TOLERANCE_RAD
                    };
                    let steps = 20_000;
                    for k in 0..=steps {
                        let r = plan.eval(k as f32 * plan.duration_s() / steps as f32);
                        let torque = l.inertia_kgm2 * r.acc.abs() + l.coulomb_nm
                            + l.viscous_nms * r.vel.abs();
                        prop_assert!(torque <= l.torque_budget_nm() * 1.0001, "torque {torque}");
                        prop_assert!(r.vel.abs() <= l.max_speed_rad_s * 1.0001);
                        prop_assert!(in_range(r.pos));
                    }
                    prop_assert_eq!(plan.start(), from);
                    prop_assert_eq!(plan.end(), *targets.last().unwrap());
                    if let (Some(t), false) = (time, shaped) {
                        prop_assert!((plan.duration_s() - t).abs() < 1e-4);
                    }
                }
                Err(PlanError::TooFast { needs_s }) => {
                    let t = time.unwrap_or(at);
                    prop_assert!(needs_s > t, "needs {needs_s}, given {t}");
                    // The time it names works (the waypoints' own times, uniformly slowed).
                    let slowed: heapless::Vec<Waypoint, MAX_WAYPOINTS> = waypoints
                        .iter()
                        .map(|w| Waypoint { rad: w.rad, at_s: w.at_s.map(|a| a * (needs_s / at)) })
                        .collect();
                    let again = if gaps.is_some() {
                        plan_through(from, &slowed, None, &shaper, &l)
                    } else {
                        plan_through(from, &waypoints, Some(needs_s), &shaper, &l)
                    };
                    prop_assert!(again.is_ok(), "{again:?}");
                }
                Err(PlanError::OutOfRange { .. }) => {}
                // Only waypoints so close in time that, slowed to keep the limits, they
                // would last longer than the longest move (a given time here is 2 s at most).
                Err(PlanError::TooLong { max_s }) => {
                    prop_assert_eq!(max_s, MAX_MOVE_S);
                    prop_assert!(gaps.is_some());
                }
                Err(PlanError::TimesNotIncreasing) => {
                    prop_assert!(gaps.is_some_and(|g| g.iter().any(|&x| x < 1e-3)));
                }
                Err(e) => prop_assert!(false, "unexpected refusal {e:?}"),
            }
        }
    }
}
