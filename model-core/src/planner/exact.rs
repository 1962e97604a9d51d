//! A shortest move planned to leave a law's reference beam at rest (docs/design.md,
//! section 3, "A reference exact on the reference beam").
//!
//! The observer laws run a *reference beam* beside the reference: the beam's first two
//! modes as the reference's own torque swings them with the hub free, sampled at the tick,
//! with the centrifugal term of the hub's rate ([`ReferenceBeam`]). Whatever it still
//! rings with when the reference stops is what the real beam rings with, and the feedback
//! then has to damp it. A shaper tuned to the mode at rest does not cancel it (the
//! frequency moves with the hub's speed), so this planner makes the cancellation exact on
//! the reference beam as the tick runs it:
//!
//! - the base is bang-coast-bang: a constant acceleration at the torque budget (and the
//!   strain budget's), reached and left over [`RAMP_S`] of constant jerk, a coast at the
//!   speed limit if the move is long enough, and the same backwards;
//! - it is shaped by two pairs of impulses: one on the second mode (a ZV at the reference
//!   beam's second frequency at rest), and one on the first whose share and delay are
//!   solved by Newton's method so that the reference beam's first mode ends at rest, its
//!   residual found by running the reference beam through the whole shaped move tick by
//!   tick, as the law does;
//! - the plan is kept only if that run's root strain stays within [`MAX_PEAK_STRAIN`].
//!
//! All in `f32`, outside the tick: a move's plan costs up to [`NEWTON_STEPS`] times three
//! runs of the reference beam over the move, about 30 multiply-adds a tick (some 300 000
//! for a 0.4 s move).

use super::{Limits, Plan, PlanError, MIN_SEGMENT_S};
use crate::knots::BASE_KNOTS;
use crate::shaper::Impulses;
use crate::spline::{held_acceleration, Spline};
use beam_model::lqg::{LqgDesign, DESIGN_MODES};

/// The constant-jerk ramps in and out of the base move's acceleration, s. Shorter ramps
/// end the move sooner; each ramp's jerk excites the second mode (36.9 Hz on the model, a
/// 27 ms period), which its ZV then cancels.
pub const RAMP_S: f32 = 0.01;

/// Newton steps on the first mode's pair; each runs the reference beam over the move three
/// times. Four reach a residual of a few microstrain from the ZV's start; the rest are for
/// beams further off.
pub const NEWTON_STEPS: usize = 8;

/// The largest residual the planner accepts, in strain at the root: the reference beam's
/// first-mode amplitude (its coordinate and its rate over its angular frequency). Above it
/// the planner falls back to the shaped quintic.
pub const MAX_RESIDUAL_STRAIN: f32 = 2e-6;

/// The largest root strain the exact move's reference beam may reach during the move: above
/// it the planner plans the shaped quintic instead. On a beam the drive knows, the beam
/// follows its reference beam and bends as far (over 1400 drawn beams known to the drive,
/// 20 % off the model, the plans within it bent them to at most 1805 ue), so this keeps the
/// moves within the 2000 ue a move is held to, with the rest for the feedback. The budget on
/// the base's static strain ([`Limits::strain_budget`]) does not: the pair that cancels the
/// first mode at the end is not a ZV during the move, and the mode overshoots the static
/// strain by up to two fifths (2420 ue at 120 deg on such beams).
pub const MAX_PEAK_STRAIN: f32 = 1.8e-3;

/// A run of the reference beam over a move ([`ReferenceBeam::run`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Run {
    /// Its state when the reference comes to rest at the end, `[q_0, q_1, q_0', q_1']` (m
    /// and m/s).
    pub state: [f32; 2 * DESIGN_MODES],
    /// The largest root strain of its two modes on the way.
    pub peak_strain: f32,
}

/// A law's reference beam as the tick runs it (`LqgDesign::ref_ad` and the fields beside
/// it): what the planner needs of the law's design, and nothing else.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ReferenceBeam {
    /// The sampled modes and rates, `r+ = ad r + bd theta_r''`.
    pub ad: [[f32; 2 * DESIGN_MODES]; 2 * DESIGN_MODES],
    /// The input column, per rad/s^2.
    pub bd: [f32; 2 * DESIGN_MODES],
    /// The hub's turn about the rigid reference per modal coordinate.
    pub hub: [f32; DESIGN_MODES],
    /// The centrifugal term per (rad/s)^2 of hub rate, per tick.
    pub centrifugal: [[f32; DESIGN_MODES]; DESIGN_MODES],
    /// Root strain per modal coordinate.
    pub strain: [f32; DESIGN_MODES],
    /// The modes' frequencies at rest, Hz.
    pub hz: [f32; DESIGN_MODES],
    /// The tick, s.
    pub ts_s: f32,
}

impl ReferenceBeam {
    /// The reference beam of `design`, run every `ts_s` (its frequencies at rest, the
    /// planner's starting points, are the design's `ref_hz`); `None` for a design without a
    /// reference beam (a law with no observer: its frequencies are zero) or a tick that is
    /// not positive.
    pub fn of(design: &LqgDesign, ts_s: f32) -> Option<Self> {
        let hz = design.ref_hz;
        let usable = hz[0] > 0.0 && hz[1] > 0.0 && ts_s > 0.0;
        usable.then_some(ReferenceBeam {
            ad: design.ref_ad,
            bd: design.ref_bd,
            hub: design.ref_hub,
            centrifugal: design.ref_s,
            strain: design.strain_coef,
            hz,
            ts_s,
        })
    }

    /// Runs the reference beam over `spline` as the law's tick does (the tick `k` at `k
    /// ts`; its modes step on the acceleration held over the tick,
    /// [`crate::spline::held_acceleration`], and on the reference state's rate squared), and
    /// returns its state when the reference comes to rest at the end and its peak root
    /// strain on the way. (A restatement of the tick's step, which is unrolled for its
    /// instruction budget; a test holds the two to the same state.)
    pub fn run<const K: usize>(&self, spline: &Spline<K>) -> Run {
        let mut r = [0.0f32; 2 * DESIGN_MODES];
        let mut segment = 0;
        let mut last_acc = 0.0;
        let mut peak_strain = 0.0f32;
        let end = spline.duration_s();
        // At most a minute of ticks (`MAX_MOVE_S`): the count bounds the loop.
        for k in 0..(super::MAX_MOVE_S / self.ts_s) as u32 + 2 {
            let t = k as f32 * self.ts_s;
            if t >= end {
                break;
            }
            let p = spline.eval_from(&mut segment, t);
            // The acceleration held over the tick, as the law takes it.
            let acc = held_acceleration(p.acc, last_acc);
            last_acc = p.acc;
            if p.vel == 0.0 && acc == 0.0 {
                r = [0.0; 2 * DESIGN_MODES];
                continue;
            }
            let vel = p.vel + self.hub[0] * r[2] + self.hub[1] * r[3];
            let w2 = vel * vel;
            let mut next = [0.0f32; 2 * DESIGN_MODES];
            for (i, n) in next.iter_mut().enumerate() {
                let mut z = self.bd[i] * acc;
                for (a, x) in self.ad[i].iter().zip(r.iter()) {
                    z += a * x;
                }
                if let Some(s) = i
                    .checked_sub(DESIGN_MODES)
                    .and_then(|m| self.centrifugal.get(m))
                {
                    z += w2 * (s[0] * r[0] + s[1] * r[1]);
                }
                *n = z;
            }
            r = next;
            peak_strain =
                peak_strain.max(libm::fabsf(self.strain[0] * r[0] + self.strain[1] * r[1]));
        }
        Run {
            state: r,
            peak_strain,
        }
    }

    /// The first mode's residual in root strain: its coordinate, and its rate over its
    /// angular frequency (of a state [`ReferenceBeam::run`] returns).
    pub fn first_mode(&self, r: &[f32; 2 * DESIGN_MODES]) -> [f32; 2] {
        let w = 2.0 * core::f32::consts::PI * self.hz[0];
        let e = self.strain[0];
        [e * r[0], e * r[2] / w]
    }
}

/// The bang-coast-bang base from `from` to `to` within `limits` ([`RAMP_S`] ramps), or
/// `None` if the limits leave it no acceleration.
pub fn base(from: f32, to: f32, limits: &Limits) -> Option<Spline<BASE_KNOTS>> {
    let d = libm::fabsf(to - from);
    let sign = if to >= from { 1.0 } else { -1.0 };
    let vmax = limits.max_speed_rad_s;
    // The acceleration the torque leaves at the top speed, and the strain budget's.
    let room = limits.torque_budget_nm() - limits.coulomb_nm - limits.viscous_nms * vmax;
    let mut a = room / limits.inertia_kgm2;
    if limits.strain_budget > 0.0 && limits.strain_per_acc != 0.0 {
        a = a.min(limits.strain_budget / libm::fabsf(limits.strain_per_acc));
    }
    // A margin against the f32 rounding of the rebuilt spline (the check is on its peaks).
    a *= 0.998;
    if !(a > 0.0 && d > 0.0 && vmax > 0.0) {
        return None;
    }
    let j = RAMP_S;
    // u = ramp + constant acceleration: the time the speed takes to reach its peak, a u.
    // (The peak speed a hair under the limit: the check's bound on the rebuilt spline's
    // speed is safe, and a little above the exact peak.)
    let vmax = 0.998 * vmax;
    let mut u = (vmax / a).max(j);
    if u - j < MIN_SEGMENT_S {
        u = j;
    }
    let v = (a * u).min(vmax);
    // Too short to coast: the peak speed a u with a u (u + j) = d.
    let mut coast = d / v - (u + j);
    if coast < MIN_SEGMENT_S {
        coast = 0.0;
        u = 0.5 * (-j + beam_model::sqrt::sqrtf(j * j + 4.0 * d / a));
        if u - j < MIN_SEGMENT_S {
            // Not even the ramps at full acceleration: ramps alone, at a lower one.
            u = j;
            a = d / (2.0 * j * j);
        }
    }
    let ta = u - j;
    // The knots (time, position, speed, acceleration), forward; zero-length pieces left out.
    let mut states = [(0.0f32, 0.0f32, 0.0f32, 0.0f32); 8];
    let (mut t, mut p, mut s, mut acc) = (0.0f32, 0.0f32, 0.0f32, 0.0f32);
    let mut n = 1;
    // Each piece: its length and its jerk; position, speed and acceleration carried exactly.
    let jerk = a / j;
    let pieces = [
        (j, jerk),
        (ta, 0.0),
        (j, -jerk),
        (coast, 0.0),
        (j, -jerk),
        (ta, 0.0),
        (j, jerk),
    ];
    for (h, jk) in pieces {
        if h <= 0.0 {
            continue;
        }
        p += s * h + acc * h * h / 2.0 + jk * h * h * h / 6.0;
        s += acc * h + jk * h * h / 2.0;
        acc += jk * h;
        t += h;
        if let Some(slot) = states.get_mut(n) {
            *slot = (t, from + sign * p, sign * s, sign * acc);
            n += 1;
        }
    }
    // The end exactly at rest on the target.
    if let Some(last) = states.get_mut(n - 1) {
        *last = (t, to, 0.0, 0.0);
    }
    states[0] = (0.0, from, 0.0, 0.0);
    Spline::try_from_states(states.get(..n)?).ok()
}

/// The shortest move from `from` to `to` that leaves `beam` at rest, as above; `Ok(None)`
/// when it cannot be made (no acceleration, Newton's method left more than
/// [`MAX_RESIDUAL_STRAIN`], or the reference beam bends past [`MAX_PEAK_STRAIN`] on the
/// way), for the caller to plan otherwise.
pub fn plan(
    from: f32,
    to: f32,
    limits: &Limits,
    beam: &ReferenceBeam,
) -> Result<Option<Plan>, PlanError> {
    let Some(base) = base(from, to, limits) else {
        return Ok(None);
    };
    // The second mode's ZV at its frequency at rest, undamped (at the model's 1 % the
    // amplitudes would move by under 2 %; the mode's ringing is what the ramps' jerk
    // starts, and the ZV leaves the reference beam's second mode within about 1 ue).
    let second = Impulses::pair(0.5, 0.5 / beam.hz[1]);
    let train = |share: f32, delay: f32| Impulses::pair(share, delay).then(&second);
    // From the first mode's ZV at rest (undamped).
    let (mut share, mut delay) = (0.5f32, 0.5 / beam.hz[0]);
    let plan_at = |share: f32, delay: f32| -> Result<Plan, PlanError> {
        let train = train(share, delay).ok_or(PlanError::Unplannable)?;
        Plan::shaped_by(base.clone(), &train)
    };
    let (ds, dt) = (1e-3f32, 1e-4f32);
    // The residual at each step, and the plan made again for the one kept (the same plan:
    // carrying it out of each step cost the board's flash more than its time).
    let residual = |share: f32, delay: f32| -> Result<([f32; 2], f32), PlanError> {
        let plan = plan_at(share, delay)?;
        let run = beam.run(&plan.shaped);
        Ok((beam.first_mode(&run.state), run.peak_strain))
    };
    for step in 0..=NEWTON_STEPS {
        let (r0, peak) = residual(share, delay)?;
        let size = libm::fabsf(r0[0]).max(libm::fabsf(r0[1]));
        // Done when well within the tolerance; after the last step, if within it at all;
        // and only if the reference beam stays within its strain on the way.
        if size < 0.1 * MAX_RESIDUAL_STRAIN || step == NEWTON_STEPS {
            return if size < MAX_RESIDUAL_STRAIN && peak <= MAX_PEAK_STRAIN {
                plan_at(share, delay).map(Some)
            } else {
                Ok(None)
            };
        }
        let (rs, _) = residual(share + ds, delay)?;
        let (rt, _) = residual(share, delay + dt)?;
        // The Jacobian by columns, and its solve.
        let (a, c) = ((rs[0] - r0[0]) / ds, (rs[1] - r0[1]) / ds);
        let (b, d) = ((rt[0] - r0[0]) / dt, (rt[1] - r0[1]) / dt);
        let det = a * d - b * c;
        if !(det.is_finite() && det != 0.0) {
            return Ok(None);
        }
        // The step, shortened to at most 0.1 of share and a tenth of the delay: far from the
        // solution the residual is far from linear in them.
        let (step_s, step_t) = ((d * r0[0] - b * r0[1]) / det, (a * r0[1] - c * r0[0]) / det);
        let cut = (libm::fabsf(step_s) / 0.1)
            .max(libm::fabsf(step_t) / (0.1 * delay))
            .max(1.0);
        share -= step_s / cut;
        delay -= step_t / cut;
        if !(share > 0.05 && share < 0.95 && delay > MIN_SEGMENT_S && delay.is_finite()) {
            return Ok(None);
        }
    }
    Ok(None)
}
