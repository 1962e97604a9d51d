//! The hub-angle reference: rest-to-rest C2 splines of fixed capacity.
//!
//! Each segment is a quintic Hermite polynomial matching position, velocity and acceleration
//! at both of its knots, so the spline is C2 by construction and its acceleration (which the
//! control law feeds forward) is continuous. With two knots it is the minimum-jerk quintic
//! `p0 + (p1-p0)(10 tau^3 - 15 tau^4 + 6 tau^5)` of the paper. Interior knot velocities and
//! accelerations come from central differences of the knot positions; the end knots are at
//! rest. Before the first knot and after the last the reference is held at rest.

pub use crate::error::SplineError;
use heapless::Vec;

/// Reference position, velocity and acceleration at one instant (rad, rad/s, rad/s^2).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct RefPoint {
    /// Position, rad.
    pub pos: f32,
    /// Velocity, rad/s.
    pub vel: f32,
    /// Acceleration, rad/s^2.
    pub acc: f32,
}

/// The reference's acceleration averaged over the tick that starts at a point whose
/// acceleration is `acc`, the last tick's having been `last_acc`: `acc + (acc - last_acc) /
/// 2`, exact for an acceleration linear in time. What the controller gives the observer laws
/// while a move runs (`Controller`'s tick, [`HELD_LEAD`]), for their feedforward and their
/// reference beam, and what the host's exact planner runs the reference beam on.
///
/// The torque a tick computes is held until the next (a zero-order hold), so the hub gains
/// the acceleration it is given over the whole tick. Given the acceleration at the tick's
/// start, it ends each tick with the speed the reference had half a tick before: behind
/// the reference by half a tick of its speed (0.57 deg at 20 rad/s at 1 kHz), which the
/// feedback then pulls at through the whole move. The same holds for a reference beam
/// stepped by the acceleration at its start: it is sampled as the hub is driven, so it
/// describes the beam the held torque actually swings only with the held acceleration.
/// (The other laws keep the acceleration at the tick's start: they have no reference beam,
/// and on them the change moved settle times that hang on the strict band's edge by
/// seconds, either way.)
#[inline(always)]
pub fn held_acceleration(acc: f32, last_acc: f32) -> f32 {
    acc + HELD_LEAD * (acc - last_acc)
}

/// The share of the last tick's change in the reference's acceleration that
/// [`held_acceleration`] adds to it: half a tick's worth.
pub const HELD_LEAD: f32 = 0.5;

/// One segment: start time, duration, and coefficients in normalised time tau in [0, 1].
#[derive(Clone, Copy, Debug, PartialEq)]
struct Segment {
    t0_s: f32,
    h_s: f32,
    d: [f32; 6],
}

impl Segment {
    /// The quintic Hermite segment from `(t0, p0, v0, a0)` to `(t1, p1, v1, a1)`, in
    /// tau = (t - t0)/h with velocities and accelerations scaled to it.
    #[inline(never)]
    fn hermite(
        (t0, p0, v0, a0): (f32, f32, f32, f32),
        (t1, p1, v1, a1): (f32, f32, f32, f32),
    ) -> Segment {
        let h = t1 - t0;
        let (dp, v0, v1, a0, a1) = (p1 - p0, v0 * h, v1 * h, a0 * h * h, a1 * h * h);
        let d = [
            p0,
            v0,
            0.5 * a0,
            10.0 * dp - 6.0 * v0 - 4.0 * v1 - 1.5 * a0 + 0.5 * a1,
            -15.0 * dp + 8.0 * v0 + 7.0 * v1 + 1.5 * a0 - a1,
            6.0 * dp - 3.0 * v0 - 3.0 * v1 - 0.5 * a0 + 0.5 * a1,
        ];
        Segment {
            t0_s: t0,
            h_s: h,
            d,
        }
    }
}

/// A rest-to-rest C2 spline with at most `K` knots (`K - 1` segments).
#[derive(Clone, Debug, PartialEq)]
pub struct Spline<const K: usize> {
    segments: Vec<Segment, K>,
    start: f32,
    end: f32,
    duration_s: f32,
}

/// The knots' rules, for `n` knots whose `knot(i)` gives the time and whether the rest of
/// the knot is finite: 2 to `capacity` knots, all finite, the first at t = 0, times
/// increasing. One copy for every spline's capacity (the drive's flash).
#[inline(never)]
fn check_knots(
    n: usize,
    capacity: usize,
    knot: &dyn Fn(usize) -> (f32, bool),
) -> Result<(), SplineError> {
    if n < 2 {
        return Err(SplineError::TooFewKnots);
    }
    if n > capacity {
        return Err(SplineError::TooManyKnots { capacity });
    }
    for index in 0..n {
        let (t, rest_finite) = knot(index);
        if !(t.is_finite() && rest_finite) {
            return Err(SplineError::NonFinite { index });
        }
    }
    if knot(0).0 != 0.0 {
        return Err(SplineError::FirstKnotNotAtZero);
    }
    for index in 1..n {
        if !(knot(index).0 > knot(index - 1).0) {
            return Err(SplineError::TimesNotIncreasing { index });
        }
    }
    Ok(())
}

impl<const K: usize> Spline<K> {
    /// The paper's single-segment minimum-jerk move from `from` to `to` in `duration_s`.
    pub fn quintic(from: f32, to: f32, duration_s: f32) -> Result<Self, SplineError> {
        Self::try_build(&[(0.0, from), (duration_s, to)])
    }

    /// A spline through `knots` given as `(time_s, position_rad)`, starting at t = 0.
    pub fn try_build(knots: &[(f32, f32)]) -> Result<Self, SplineError> {
        let n = knots.len();
        // By `get`: no bounds-check panic on the drive's command path (every index is below
        // `n`, which `check` has bounded).
        let knot = |i: usize| knots.get(i).copied().unwrap_or((0.0, 0.0));
        check_knots(n, K, &|i| (knot(i).0, knot(i).1.is_finite()))?;
        // Knot velocities and accelerations: rest at the ends, central differences inside.
        let slope = |i: usize| (knot(i + 1).1 - knot(i).1) / (knot(i + 1).0 - knot(i).0);
        let vel_acc = |i: usize| -> (f32, f32) {
            if i == 0 || i == n - 1 {
                return (0.0, 0.0);
            }
            let span = knot(i + 1).0 - knot(i - 1).0;
            let v = (knot(i + 1).1 - knot(i - 1).1) / span;
            let a = 2.0 * (slope(i) - slope(i - 1)) / span;
            (v, a)
        };
        let mut segments = Vec::new();
        for i in 0..n - 1 {
            let (t0, p0) = knot(i);
            let (t1, p1) = knot(i + 1);
            let (v0, a0) = vel_acc(i);
            let (v1, a1) = vel_acc(i + 1);
            // Capacity K holds K knots, so K - 1 segments always fit.
            let _ = segments.push(Segment::hermite((t0, p0, v0, a0), (t1, p1, v1, a1)));
        }
        Ok(Self {
            segments,
            start: knot(0).1,
            end: knot(n - 1).1,
            duration_s: knot(n - 1).0,
        })
    }

    /// A spline through `states` given as `(time_s, position, velocity, acceleration)`, each
    /// segment the quintic matching both of its ends: for a reference that is itself
    /// piecewise quintic between these times (a shaped quintic), it is that reference
    /// exactly. Starts at t = 0; the first and last states should be at rest.
    pub fn try_from_states(states: &[(f32, f32, f32, f32)]) -> Result<Self, SplineError> {
        let n = states.len();
        // By `get`: no bounds-check panic on the drive's command path.
        let state = |i: usize| states.get(i).copied().unwrap_or_default();
        check_knots(n, K, &|i| {
            let (t, p, v, a) = state(i);
            (t, p.is_finite() && v.is_finite() && a.is_finite())
        })?;
        let mut segments = Vec::new();
        for (a, b) in states.iter().zip(states.iter().skip(1)) {
            let _ = segments.push(Segment::hermite(*a, *b));
        }
        let last = state(n.saturating_sub(1));
        Ok(Self {
            segments,
            start: state(0).1,
            end: last.1,
            duration_s: last.0,
        })
    }

    /// Position, velocity and acceleration at `t_s` seconds after the start of the move,
    /// held at rest before 0 and after the duration. A NaN time gives the start point. (A
    /// move that starts in motion, a stop, has its speed at t = 0.)
    pub fn eval(&self, t_s: f32) -> RefPoint {
        self.eval_from(&mut self.segment_at(t_s), t_s)
    }

    /// [`Spline::eval`] for times that do not decrease from one call to the next (a move's
    /// ticks), with `segment` the segment the last call used: the search goes forward from
    /// it, usually not at all, instead of back from the last knot. The same point as `eval`
    /// whenever `segment` is at most the segment holding `t_s` (0 always is; see
    /// [`Spline::segment_at`]). A tick costs 8 instructions on the drive for each segment
    /// `eval` looks past.
    #[inline(always)]
    pub fn eval_from(&self, segment: &mut usize, t_s: f32) -> RefPoint {
        let at_rest = |pos| RefPoint {
            pos,
            vel: 0.0,
            acc: 0.0,
        };
        if !(t_s >= 0.0) {
            return at_rest(self.start);
        }
        if t_s >= self.duration_s {
            return at_rest(self.end);
        }
        let mut i = *segment;
        let mut rest = self.segments.get(i..).unwrap_or_default();
        while let [_, tail @ ..] = rest {
            match tail.first() {
                Some(next) if t_s >= next.t0_s => {
                    rest = tail;
                    i += 1;
                }
                _ => break,
            }
        }
        *segment = i;
        // A built spline has at least one segment; the fallback keeps this path free of
        // index panics all the same (the firmware's tick is checked to contain none).
        match rest.first() {
            Some(seg) => Self::eval_in(seg, t_s),
            None => at_rest(self.start),
        }
    }

    /// The segment [`Spline::eval`] uses at `t_s` (0 before the first knot and for a NaN
    /// time): where [`Spline::eval_from`] may start for times from `t_s` on.
    pub fn segment_at(&self, t_s: f32) -> usize {
        self.segments
            .iter()
            .rposition(|s| t_s >= s.t0_s)
            .unwrap_or(0)
    }

    /// Evaluates one segment's polynomial at `t_s`, a time within that segment: `t0 <= t_s
    /// <= t0 + h` (where [`Spline::eval_from`] calls it, `t_s` is at least the segment's
    /// start and below the next knot or the end). Then `tau` is within [0, 1] as computed,
    /// with no clamp: rounding is monotonic, so `t_s - t0` rounds to at most `t1 - t0`,
    /// which is `h` as stored, and a quotient of two such numbers to at most 1.
    fn eval_in(seg: &Segment, t_s: f32) -> RefPoint {
        let tau = (t_s - seg.t0_s) / seg.h_s;
        debug_assert!((0.0..=1.0).contains(&tau), "tau {tau} outside its segment");
        let d = &seg.d;
        let pos = d[0] + tau * (d[1] + tau * (d[2] + tau * (d[3] + tau * (d[4] + tau * d[5]))));
        let vel =
            d[1] + tau * (2.0 * d[2] + tau * (3.0 * d[3] + tau * (4.0 * d[4] + tau * 5.0 * d[5])));
        let acc = 2.0 * d[2] + tau * (6.0 * d[3] + tau * (12.0 * d[4] + tau * 20.0 * d[5]));
        RefPoint {
            pos,
            vel: vel / seg.h_s,
            acc: acc / (seg.h_s * seg.h_s),
        }
    }

    /// Total move time, s.
    pub fn duration_s(&self) -> f32 {
        self.duration_s
    }

    /// Start position, rad.
    pub fn start(&self) -> f32 {
        self.start
    }

    /// Final position, rad.
    pub fn end(&self) -> f32 {
        self.end
    }

    /// Knot times, s (the segment boundaries and the end).
    pub fn knot_times(&self) -> impl Iterator<Item = f32> + '_ {
        self.segments
            .iter()
            .map(|s| s.t0_s)
            .chain(core::iter::once(self.duration_s))
    }

    /// The knots as states `(time, position, velocity, acceleration)`: what
    /// [`Spline::try_from_states`] rebuilds this spline from (into any capacity `M` that
    /// holds its knots; extra knots are dropped).
    pub fn states<const M: usize>(&self) -> Vec<(f32, f32, f32, f32), M> {
        let mut out = Vec::new();
        for t in self.knot_times() {
            let r = self.eval(t);
            if out.push((t, r.pos, r.vel, r.acc)).is_err() {
                break;
            }
        }
        out
    }

    /// Bounds on the reference over the whole move, safe upper bounds (not samples): the
    /// acceleration's extremes are exact (each segment's acceleration is a cubic whose
    /// turning points solve a quadratic); velocity and position are sampled
    /// [`PEAK_SAMPLES`] times per segment and widened by the most they can rise between a
    /// turning point and the nearest sample (from the exact jerk and acceleration bounds).
    /// Worked out in `f32`, each bound widened by 16 of its `f32` steps against rounding.
    /// For planning, outside the tick.
    pub fn peaks(&self) -> Peaks {
        peaks_of(&self.segments, self.start, self.end)
    }
}

/// [`Spline::peaks`], for any capacity (one copy in the firmware, not one per `K`).
fn peaks_of(segments: &[Segment], start: f32, end: f32) -> Peaks {
    let mut p = Peaks {
        min_pos: start.min(end),
        max_pos: start.max(end),
        max_abs_vel: 0.0,
        max_abs_acc: 0.0,
    };
    for seg in segments {
        let (d, h) = (&seg.d, seg.h_s);
        // p''(tau) = 2 d2 + 6 d3 tau + 12 d4 tau^2 + 20 d5 tau^3; its turning points
        // solve 6 d3 + 24 d4 tau + 60 d5 tau^2 = 0.
        let acc = |t: f32| {
            (2.0 * d[2] + t * (6.0 * d[3] + t * (12.0 * d[4] + t * 20.0 * d[5]))) / (h * h)
        };
        let mut a_max = libm::fabsf(acc(0.0)).max(libm::fabsf(acc(1.0)));
        let (qa, qb, qc) = (60.0 * d[5], 24.0 * d[4], 6.0 * d[3]);
        let mut roots = [f32::NAN; 2];
        if qa != 0.0 {
            let disc = qb * qb - 4.0 * qa * qc;
            if disc >= 0.0 {
                let r = beam_model::sqrt::sqrtf(disc);
                roots = [(-qb + r) / (2.0 * qa), (-qb - r) / (2.0 * qa)];
            }
        } else if qb != 0.0 {
            roots[0] = -qc / qb;
        }
        for t in roots {
            if (0.0..=1.0).contains(&t) {
                a_max = a_max.max(libm::fabsf(acc(t)));
            }
        }
        // The jerk is a quadratic in tau, extreme at the ends or at its vertex.
        let jerk = |t: f32| (6.0 * d[3] + t * (24.0 * d[4] + t * 60.0 * d[5])) / (h * h * h);
        let mut j_max = libm::fabsf(jerk(0.0)).max(libm::fabsf(jerk(1.0)));
        if d[5] != 0.0 {
            let vertex = -24.0 * d[4] / (120.0 * d[5]);
            if (0.0..=1.0).contains(&vertex) {
                j_max = j_max.max(libm::fabsf(jerk(vertex)));
            }
        }
        let vel = |t: f32| {
            (d[1] + t * (2.0 * d[2] + t * (3.0 * d[3] + t * (4.0 * d[4] + t * 5.0 * d[5])))) / h
        };
        let pos = |t: f32| d[0] + t * (d[1] + t * (d[2] + t * (d[3] + t * (d[4] + t * d[5]))));
        // An extreme inside the segment is a turning point (zero derivative), so from
        // there to the nearest sample, at most dt/2 away, the value changes by at most
        // (bound on its second derivative) * (dt/2)^2 / 2; an extreme at an end is a
        // sample.
        let dt = h / PEAK_SAMPLES as f32;
        let (mut v_max, mut lo, mut hi) = (0.0f32, f32::INFINITY, f32::NEG_INFINITY);
        for i in 0..=PEAK_SAMPLES {
            let t = i as f32 / PEAK_SAMPLES as f32;
            v_max = v_max.max(libm::fabsf(vel(t)));
            let x = pos(t);
            lo = lo.min(x);
            hi = hi.max(x);
        }
        let v_bound = v_max + j_max * dt * dt / 8.0;
        let p_slack = a_max * dt * dt / 8.0;
        p.max_abs_acc = p.max_abs_acc.max(widen(a_max));
        p.max_abs_vel = p.max_abs_vel.max(widen(v_bound));
        p.min_pos = p.min_pos.min(-widen(-(lo - p_slack)));
        p.max_pos = p.max_pos.max(widen(hi + p_slack));
    }
    p
}

/// `x` moved up by 16 of its own `f32` steps: the bounds are worked out in `f32` (the drive
/// has no double-precision hardware), where the few roundings of a polynomial's value and of
/// a turning point's place could leave a bound a step or two below the value it bounds.
fn widen(x: f32) -> f32 {
    x + libm::fabsf(x) * (16.0 * f32::EPSILON)
}

/// Samples per segment behind [`Spline::peaks`]' velocity and position bounds.
pub const PEAK_SAMPLES: usize = 64;

/// Bounds on a move's reference: see [`Spline::peaks`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Peaks {
    /// Lowest position, rad.
    pub min_pos: f32,
    /// Highest position, rad.
    pub max_pos: f32,
    /// Largest speed, rad/s.
    pub max_abs_vel: f32,
    /// Largest acceleration magnitude, rad/s^2.
    pub max_abs_acc: f32,
}

/// The paper's slew, the default move everywhere: -90 deg to +90 deg in 0.35 s, rest to rest.
pub mod paper_slew {
    /// Start, rad.
    pub const FROM_RAD: f32 = -core::f32::consts::FRAC_PI_2;
    /// End, rad.
    pub const TO_RAD: f32 = core::f32::consts::FRAC_PI_2;
    /// Duration AT, ms (exact: `f64` users take `TIME_MS as f64 / 1000.0`, the nearest
    /// double to 0.35).
    pub const TIME_MS: u32 = 350;
    /// Duration AT, s (the nearest `f32` to 0.35).
    pub const TIME_S: f32 = TIME_MS as f32 / 1000.0;
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn close(a: f32, b: f32, tol: f32) -> bool {
        (a - b).abs() <= tol * (1.0 + b.abs())
    }

    #[test]
    fn quintic_matches_the_minimum_jerk_polynomial() {
        let (p0, p1, t) = (-1.2_f32, 1.7_f32, 0.35_f32);
        let s = Spline::<2>::quintic(p0, p1, t).unwrap();
        for k in 0..=70 {
            let time = t * k as f32 / 70.0;
            let tau = time / t;
            let expect =
                p0 + (p1 - p0) * (10.0 * tau.powi(3) - 15.0 * tau.powi(4) + 6.0 * tau.powi(5));
            let vexp = (p1 - p0) * 30.0 * tau * tau * (1.0 - tau).powi(2) / t;
            assert!(close(s.eval(time).pos, expect, 1e-5));
            assert!(close(s.eval(time).vel, vexp, 1e-4));
        }
        // Peak velocity of the minimum-jerk move is 15/8 of the mean.
        assert!(close(s.eval(t / 2.0).vel, 1.875 * (p1 - p0) / t, 1e-5));
        assert!(close(s.eval(t / 2.0).acc, 0.0, 1e-4));
    }

    #[test]
    fn build_errors_are_precise() {
        assert_eq!(
            Spline::<4>::try_build(&[(0.0, 1.0)]),
            Err(SplineError::TooFewKnots)
        );
        assert_eq!(
            Spline::<2>::try_build(&[(0.0, 0.0), (1.0, 1.0), (2.0, 0.0)]),
            Err(SplineError::TooManyKnots { capacity: 2 })
        );
        assert_eq!(
            Spline::<4>::try_build(&[(0.0, 0.0), (1.0, f32::NAN)]),
            Err(SplineError::NonFinite { index: 1 })
        );
        assert_eq!(
            Spline::<4>::try_build(&[(0.1, 0.0), (1.0, 1.0)]),
            Err(SplineError::FirstKnotNotAtZero)
        );
        assert_eq!(
            Spline::<4>::try_build(&[(0.0, 0.0), (1.0, 1.0), (1.0, 2.0)]),
            Err(SplineError::TimesNotIncreasing { index: 2 })
        );
        assert!(Spline::<4>::quintic(0.0, 1.0, 0.0).is_err());
    }

    /// Random knot sets: strictly increasing times from 0, bounded positions.
    fn knots() -> impl Strategy<Value = std::vec::Vec<(f32, f32)>> {
        prop::collection::vec((0.02_f32..0.5, -3.0_f32..3.0), 1..7).prop_map(|steps| {
            let mut t = 0.0;
            let mut out = std::vec![(0.0, steps[0].1)];
            for (dt, p) in steps {
                t += dt;
                out.push((t, p));
            }
            out
        })
    }

    #[test]
    fn the_paper_slew_is_its_degrees_and_milliseconds_exactly() {
        // The CLI plans moves from degrees and seconds; the default move must be the paper's
        // constants to the bit, so no special case is needed for it.
        assert_eq!((-90f64).to_radians() as f32, paper_slew::FROM_RAD);
        assert_eq!(90f64.to_radians() as f32, paper_slew::TO_RAD);
        assert_eq!(0.35f64 as f32, paper_slew::TIME_S);
    }

    proptest! {
        /// The segment a time falls in is the last whose knot is at or before it, counted
        /// from the knots themselves: the cursor of a move's ticks finds it, tick by tick
        /// and at the knots (where the later segment starts), also when it starts mid-move
        /// from `segment_at` (a stop), and `eval` evaluates it.
        #[test]
        fn the_cursor_finds_the_segment_the_search_finds(k in knots(), from in 0.0_f32..1.0) {
            let s = Spline::<8>::try_build(&k).unwrap();
            let segment_of = |t: f32| k.iter().filter(|&&(t0, _)| t0 <= t).count().max(1) - 1;
            let expected = |t: f32| {
                if t >= s.duration_s() {
                    RefPoint { pos: s.end(), vel: 0.0, acc: 0.0 }
                } else {
                    Spline::<8>::eval_in(&s.segments[segment_of(t)], t)
                }
            };
            let mut times: std::vec::Vec<f32> =
                (0..=(s.duration_s() * 1000.0) as u32 + 20).map(|n| n as f32 * 1e-3).collect();
            times.extend(k.iter().map(|&(t, _)| t));
            times.sort_by(f32::total_cmp);
            let mut seg = 0;
            for &t in &times {
                prop_assert_eq!(s.eval_from(&mut seg, t), expected(t), "at {}", t);
                prop_assert_eq!(s.eval(t), expected(t), "at {}", t);
                if t < s.duration_s() {
                    prop_assert_eq!(seg, segment_of(t), "at {}", t);
                }
            }
            let t0 = from * s.duration_s();
            let mut seg = s.segment_at(t0);
            prop_assert_eq!(seg, segment_of(t0));
            for &t in times.iter().filter(|&&t| t >= t0) {
                prop_assert_eq!(s.eval_from(&mut seg, t), expected(t), "at {} from {}", t, t0);
            }
            for &(t, _) in &k[..k.len() - 1] {
                prop_assert_eq!(s.segment_at(t), segment_of(t), "at knot {}", t);
            }
            prop_assert_eq!(s.segment_at(f32::NAN), 0);
            prop_assert_eq!(s.segment_at(s.duration_s()), k.len() - 2);
        }

        #[test]
        fn passes_through_knots_at_rest_at_the_ends(k in knots()) {
            let s = Spline::<8>::try_build(&k).unwrap();
            for &(t, p) in &k {
                prop_assert!(close(s.eval(t).pos, p, 1e-4), "at {t}: {} vs {p}", s.eval(t).pos);
            }
            let (first, last) = (s.eval(0.0), s.eval(s.duration_s()));
            prop_assert_eq!((first.vel, first.acc, last.vel, last.acc), (0.0, 0.0, 0.0, 0.0));
            // Held outside the move.
            prop_assert_eq!(s.eval(-1.0).pos, k[0].1);
            prop_assert_eq!(s.eval(s.duration_s() + 5.0).pos, k[k.len() - 1].1);
        }

        #[test]
        fn is_c2_across_every_knot(k in knots()) {
            let s = Spline::<8>::try_build(&k).unwrap();
            // Evaluate both neighbouring polynomials exactly at each interior knot.
            for pair in s.segments.windows(2) {
                let t = pair[1].t0_s;
                let (a, b) = (Spline::<8>::eval_in(&pair[0], t), Spline::<8>::eval_in(&pair[1], t));
                // f32 rounding of the coefficients bounds how well the sides can agree. The
                // velocity sums terms as large as the acceleration times the segment's length,
                // so its rounding scales with that too (a short, steep segment between long
                // ones reaches 1.2e-3 rad/s on a velocity of 0.2 rad/s).
                let tol = |x: f32| 1e-4 * (1.0 + x.abs());
                let h = t - pair[0].t0_s;
                prop_assert!((a.pos - b.pos).abs() < tol(a.pos), "pos at {t}: {a:?} {b:?}");
                prop_assert!(
                    (a.vel - b.vel).abs() < 10.0 * tol(a.vel.abs() + a.acc.abs() * h),
                    "vel at {t}: {a:?} {b:?}"
                );
                prop_assert!((a.acc - b.acc).abs() < 100.0 * tol(a.acc), "acc at {t}: {a:?} {b:?}");
            }
        }
    }

    /// A rigid hub given each tick's held acceleration over the whole tick (a torque held by
    /// a zero-order hold) ends every tick on the reference's speed and angle, to the
    /// extrapolation's error; given the acceleration at the tick's start it trails the
    /// reference by half a tick of its speed, as a double integrator under a held input does.
    #[test]
    fn a_hub_given_the_held_acceleration_keeps_to_the_reference() {
        let ts = 1e-3f64;
        let spline = Spline::<2>::quintic(-1.5, 1.5, 0.3).unwrap();
        // (pos, vel) of the hub, integrated exactly over each tick in f64.
        let run = |held: bool| {
            let (mut pos, mut vel, mut last) = (-1.5f64, 0.0f64, 0.0f32);
            let (mut worst_pos, mut worst_vel) = (0.0f64, 0.0f64);
            for k in 0..300 {
                let r = spline.eval(k as f32 * ts as f32);
                let acc = if held {
                    held_acceleration(r.acc, last)
                } else {
                    r.acc
                };
                last = r.acc;
                pos += vel * ts + 0.5 * acc as f64 * ts * ts;
                vel += acc as f64 * ts;
                let next = spline.eval((k + 1) as f32 * ts as f32);
                worst_pos = worst_pos.max((pos - next.pos as f64).abs());
                worst_vel = worst_vel.max((vel - next.vel as f64).abs());
            }
            (worst_pos, worst_vel)
        };
        let (start_pos, start_vel) = run(false);
        let (held_pos, held_vel) = run(true);
        // The quintic's peak acceleration is 5.77 x 3 / 0.3^2 = 192 rad/s^2, so half a tick
        // of it is 0.096 rad/s; its peak speed, 15 rad/s, half a tick is 7.5 mrad.
        let peak_acc = 5.7735 * 3.0 / (0.3 * 0.3);
        assert!(start_vel > 0.9 * 0.5 * ts * peak_acc, "{start_vel}");
        assert!(start_pos > 0.5 * 0.5 * ts * 15.0, "{start_pos}");
        // Held: what is left is the extrapolation's error, `(5/12) ts^2 a''` a tick (the
        // tick's mean acceleration is `a + ts a'/2 + ts^2 a''/6`, the extrapolation `a + ts
        // a'/2 - ts^2 a''/4`), which sums to `(5/12) ts^2` times the change in jerk. The
        // quintic's jerk goes from 60 D / T^3 at the ends to -30 D / T^3 at the middle.
        let jerk_swing = 90.0 * 3.0 / (0.3f64 * 0.3 * 0.3);
        let bound = 5.0 / 12.0 * ts * ts * jerk_swing;
        assert!(
            held_vel < 1.1 * bound && bound < 0.05 * start_vel,
            "{held_vel} against {start_vel}"
        );
        assert!(
            held_pos < 0.05 * start_pos,
            "{held_pos} against {start_pos}"
        );
    }
}
