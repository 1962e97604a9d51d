//! Input shaping of a move's reference (docs/design.md, section 3).
//!
//! A shaper is a short train of impulses `(A_i, t_i)` with `sum A_i = 1`. Convolving a move
//! with it, `r(t) = sum A_i q(t - t_i)`, leaves a mode of frequency `f` and damping `zeta`
//! (nearly) unexcited: the vibration each impulse would start is cancelled by the others.
//! The impulse trains are the classical ones (Singer and Seering's ZV and ZVD, and the
//! extra-insensitive EI with its damped-case curve fit), the same families motion-control
//! firmware uses for printers and gantries.
//!
//! A shaped quintic is a sum of shifted quintics, so it is a piecewise quintic with a break
//! wherever one component starts or ends. Each piece is the quintic Hermite polynomial of the
//! exact position, velocity and acceleration at its ends, so [`shaped_quintic`] returns an
//! ordinary C2 [`Spline`] that the tick evaluates as cheaply as the unshaped move. Everything
//! here runs once, when a move is planned, in `f32`: the drive's FPU has no double precision,
//! and the software's 5 KB of flash are more than its board has to spare (the knots are
//! `f32` anyway; [`Impulses::residual`], for the host's analysis, is in `f64`).

use crate::spline::{Spline, SplineError};
pub use beam_kinds::ShaperKind;

pub use crate::error::ShaperError;
pub use crate::knots::MAX_IMPULSES;

/// Most impulses of a configured shaper's train (ZVD and EI have three): the shaped
/// quintic's knots are sized by it, whatever [`MAX_IMPULSES`] a build allows (so that a
/// move's knots computed by a build script fit the drive's type with or without the
/// `exact` feature).
pub const SHAPER_IMPULSES: usize = 3;

/// Breaks of a shaped move closer than this are merged into one, s. A piece a few
/// microseconds long, rebuilt in `f32` from its end states, divides position rounding by
/// its length squared and shows accelerations of thousands of rad/s^2 that the move does
/// not have; merging keeps the pieces at least a tick long, and the merged piece differs
/// from the exact sum only by a jerk step within one millisecond.
pub const MIN_BREAK_S: f32 = 1e-3;

/// A shaper as configured: which train, tuned to which mode.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Shaper {
    /// The impulse train.
    pub kind: ShaperKind,
    /// The mode's (undamped) natural frequency, Hz.
    pub freq_hz: f32,
    /// The mode's damping ratio, in [0, 1).
    pub damping: f32,
    /// EI only: the residual vibration allowed at the design frequency, as a fraction of the
    /// unshaped move's (0.05 is usual).
    pub tolerance: f32,
}

impl Shaper {
    /// No shaping.
    pub const NONE: Shaper = Shaper {
        kind: ShaperKind::None,
        freq_hz: 0.0,
        damping: 0.0,
        tolerance: 0.0,
    };

    /// The impulse train, or why the parameters are unusable.
    pub fn impulses(&self) -> Result<Impulses, ShaperError> {
        if self.kind == ShaperKind::None {
            return Ok(Impulses::ONE);
        }
        let (f, zeta, v) = (self.freq_hz, self.damping, self.tolerance);
        if !(f.is_finite() && f > 0.0) {
            return Err(ShaperError::Frequency);
        }
        if !(zeta.is_finite() && (0.0..1.0).contains(&zeta)) {
            return Err(ShaperError::Damping);
        }
        // The damped period and the decay over half of it.
        let root = beam_model::sqrt::sqrtf(1.0 - zeta * zeta);
        let period = 1.0 / (f * root);
        let k = libm::expf(-zeta * core::f32::consts::PI / root);
        let (amps, times, len) = match self.kind {
            ShaperKind::None => ([1.0, 0.0, 0.0], [0.0; 3], 1usize),
            ShaperKind::Zv => {
                let s = 1.0 + k;
                ([1.0 / s, k / s, 0.0], [0.0, period / 2.0, 0.0], 2)
            }
            ShaperKind::Zvd => {
                let s = (1.0 + k) * (1.0 + k);
                (
                    [1.0 / s, 2.0 * k / s, k * k / s],
                    [0.0, period / 2.0, period],
                    3,
                )
            }
            ShaperKind::Ei => {
                if !(v.is_finite() && v > 0.0 && v < 0.5) {
                    return Err(ShaperError::Tolerance);
                }
                // Singhose's curve fit of the damped EI shaper (exact at zeta = 0, where it is
                // ((1 + V)/4, (1 - V)/2, (1 + V)/4) at 0, T/2, T).
                let a1 = 0.24968
                    + 0.24961 * v
                    + (0.80008 + 1.23328 * v) * zeta
                    + (0.49599 + 3.17316 * v) * zeta * zeta;
                let a3 = 0.25149
                    + 0.21474 * v
                    + (-0.83249 + 1.41498 * v) * zeta
                    + (0.85181 - 4.90094 * v) * zeta * zeta;
                let t2 = 0.4999
                    + (0.46159 + 8.57843 * v) * v * zeta
                    + (4.26169 - 108.644 * v) * v * zeta * zeta
                    + (1.75601 + 336.989 * v) * v * zeta * zeta * zeta;
                let a2 = 1.0 - a1 - a3;
                ([a1, a2, a3], [0.0, t2 * period, period], 3)
            }
        };
        if amps[..len].iter().any(|a| !(*a > 0.0)) {
            return Err(ShaperError::Damping);
        }
        let mut train = Impulses::ONE;
        train.amps[..3].copy_from_slice(&amps);
        train.times[..3].copy_from_slice(&times);
        train.len = len;
        Ok(train)
    }
}

/// An impulse train: amplitudes summing to one at increasing times from zero.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Impulses {
    amps: [f32; MAX_IMPULSES],
    times: [f32; MAX_IMPULSES],
    len: usize,
}

impl Impulses {
    /// One impulse at zero: the move unshaped.
    pub const ONE: Impulses = {
        let mut amps = [0.0; MAX_IMPULSES];
        amps[0] = 1.0;
        Impulses {
            amps,
            times: [0.0; MAX_IMPULSES],
            len: 1,
        }
    };

    /// The train that applies `self` and then `other` (their convolution): each pair's
    /// product at the sum of their times, in the order of `self`'s impulses, then
    /// `other`'s. `None` if it would hold more than [`MAX_IMPULSES`].
    pub fn then(&self, other: &Impulses) -> Option<Impulses> {
        let mut train = Impulses::ONE;
        train.len = self.len * other.len;
        if train.len > MAX_IMPULSES {
            return None;
        }
        let mut slots = train.amps.iter_mut().zip(train.times.iter_mut());
        for (a, t) in self.iter() {
            for (b, u) in other.iter() {
                let (amp, time) = slots.next()?;
                (*amp, *time) = (a * b, t + u);
            }
        }
        Some(train)
    }

    /// Two impulses: `1 - share` at zero and `share` at `delay_s`, the zero-vibration
    /// family's pair (a ZV is `share = k / (1 + k)` at half a damped period).
    pub fn pair(share: f32, delay_s: f32) -> Impulses {
        let mut train = Impulses::ONE;
        (train.amps[0], train.amps[1]) = (1.0 - share, share);
        train.times[1] = delay_s;
        train.len = 2;
        train
    }

    /// `(amplitude, time_s)` of each impulse.
    pub fn iter(&self) -> impl Iterator<Item = (f32, f32)> + '_ {
        // (`take`, not slicing: no bounds-check panic on the drive's command path.)
        self.amps
            .iter()
            .copied()
            .zip(self.times.iter().copied())
            .take(self.len)
    }

    /// The time of the last impulse: how much the shaper lengthens a move, s.
    pub fn duration_s(&self) -> f32 {
        self.len
            .checked_sub(1)
            .and_then(|i| self.times.get(i))
            .copied()
            .unwrap_or(0.0)
    }

    /// The residual vibration a unit step shaped by these impulses leaves in a mode of
    /// `freq_hz` and damping `zeta`, as a fraction of the unshaped step's (the classical
    /// percentage-vibration measure; 0 means the mode is not excited at all).
    pub fn residual(&self, freq_hz: f64, zeta: f64) -> f64 {
        // In f64: a measure for the host's analysis, not the drive's planning.
        let w = 2.0 * core::f64::consts::PI * freq_hz;
        let wd = w * libm::sqrt(1.0 - zeta * zeta);
        let t_end = self.duration_s() as f64;
        let (mut c, mut s) = (0.0, 0.0);
        for (a, t) in self.iter() {
            let (a, t) = (a as f64, t as f64);
            let decay = libm::exp(-zeta * w * (t_end - t));
            c += a * decay * libm::cos(wd * t);
            s += a * decay * libm::sin(wd * t);
        }
        libm::sqrt(c * c + s * s)
    }
}

/// How a shaped move keeps its time.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Timing {
    /// The base move keeps its duration; shaping adds the shaper's length to the move.
    #[default]
    Stretch,
    /// The base move is shortened by the shaper's length, so the shaped move ends on time
    /// (with a higher peak acceleration).
    EndOnTime,
}

/// The knots a shaped quintic is built from ([`shaped_quintic_knots`]): plain data, so a
/// build script can compute a fixed move on the host and a drive rebuild the very same
/// spline from constants ([`MoveKnots::spline`]) without linking the shaping.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum MoveKnots {
    /// The paper's unshaped quintic.
    Quintic {
        /// Start, rad.
        from: f32,
        /// End, rad.
        to: f32,
        /// Duration, s.
        duration_s: f32,
    },
    /// Knot states `(time, position, velocity, acceleration)`, the first `len` of them.
    States {
        /// The states.
        states: [(f32, f32, f32, f32); 2 * SHAPER_IMPULSES],
        /// How many are used.
        len: usize,
    },
}

impl MoveKnots {
    /// The spline (what [`shaped_quintic`] returns for the same move).
    pub fn spline<const K: usize>(&self) -> Result<Spline<K>, SplineError> {
        match *self {
            MoveKnots::Quintic {
                from,
                to,
                duration_s,
            } => Spline::quintic(from, to, duration_s),
            MoveKnots::States { states, len } => {
                Spline::try_from_states(states.get(..len).ok_or(SplineError::TooFewKnots)?)
            }
        }
    }
}

/// The minimum-jerk move from `from` to `to`, shaped by `shaper`. With
/// [`Timing::EndOnTime`] it ends at `duration_s`; with [`Timing::Stretch`], the shaper's
/// length later. `K` must hold twice the shaper's impulses (6 for ZVD and EI).
pub fn shaped_quintic<const K: usize>(
    from: f32,
    to: f32,
    duration_s: f32,
    shaper: &Shaper,
    timing: Timing,
) -> Result<Spline<K>, ShaperError> {
    shaped_quintic_knots(from, to, duration_s, shaper, timing)?
        .spline()
        .map_err(ShaperError::Spline)
}

/// The knots of [`shaped_quintic`]'s move.
pub fn shaped_quintic_knots(
    from: f32,
    to: f32,
    duration_s: f32,
    shaper: &Shaper,
    timing: Timing,
) -> Result<MoveKnots, ShaperError> {
    let impulses = shaper.impulses()?;
    if shaper.kind == ShaperKind::None {
        return Ok(MoveKnots::Quintic {
            from,
            to,
            duration_s,
        });
    }
    let length = impulses.duration_s();
    let base = match timing {
        Timing::Stretch => duration_s,
        Timing::EndOnTime => duration_s - length,
    };
    if !(base.is_finite() && base > 0.0) {
        return Err(ShaperError::TooLong);
    }
    // Breaks: where each shifted quintic starts and ends. Breaks closer than
    // [`MIN_BREAK_S`] are one (see there).
    let mut breaks = [0.0f32; 2 * SHAPER_IMPULSES];
    for (i, (_, t)) in impulses.iter().enumerate() {
        breaks[2 * i] = t;
        breaks[2 * i + 1] = t + base;
    }
    let n = merge_breaks(&mut breaks[..2 * impulses.iter().count()]);
    let breaks = &breaks[..n];
    let (p0, dp) = (from, to - from);
    // The shaped move's position, velocity and acceleration at `t`.
    let state = |t: f32| -> (f32, f32, f32) {
        let (mut p, mut v, mut a) = (p0, 0.0, 0.0);
        for (amp, ti) in impulses.iter() {
            let u = ((t - ti) / base).clamp(0.0, 1.0);
            let (u2, u3) = (u * u, u * u * u);
            p += amp * dp * u3 * (10.0 - 15.0 * u + 6.0 * u2);
            if u > 0.0 && u < 1.0 {
                v += amp * dp / base * 30.0 * u2 * (1.0 - u) * (1.0 - u);
                a += amp * dp / (base * base) * 60.0 * u * (1.0 - u) * (1.0 - 2.0 * u);
            }
        }
        (p, v, a)
    };
    let mut points = [(0.0f32, 0.0f32, 0.0f32, 0.0f32); 2 * SHAPER_IMPULSES];
    for (slot, &t) in points.iter_mut().zip(breaks.iter()) {
        let (p, v, a) = state(t);
        *slot = (t, p, v, a);
    }
    // The ends are exactly at rest at the move's end points.
    points[0] = (0.0, from, 0.0, 0.0);
    points[n - 1] = (breaks[n - 1], to, 0.0, 0.0);
    Ok(MoveKnots::States {
        states: points,
        len: n,
    })
}

/// Sorts `breaks` and merges those closer than [`MIN_BREAK_S`] into the first of each run,
/// keeping the last break itself (the move's end); returns how many are left, at the front.
fn merge_breaks(breaks: &mut [f32]) -> usize {
    crate::linalg::insertion_sort(breaks);
    let Some(&last) = breaks.last() else {
        return 0;
    };
    // (By `get`: no bounds-check panic on the drive's command path; `n <= i` throughout.)
    let mut n = 0usize;
    for i in 0..breaks.len() {
        let b = breaks.get(i).copied().unwrap_or(last);
        let kept = n.checked_sub(1).and_then(|k| breaks.get(k)).copied();
        if kept.is_none_or(|k| b - k >= MIN_BREAK_S) {
            if let Some(slot) = breaks.get_mut(n) {
                *slot = b;
            }
            n += 1;
        }
    }
    if let Some(slot) = n.checked_sub(1).and_then(|k| breaks.get_mut(k)) {
        *slot = last;
    }
    n
}

/// Any move shaped by `shaper`: `r(t) = sum A_i s(t - t_i)`, stretched by the shaper's
/// length. Between the union of the move's knots shifted by each impulse time the sum is one
/// quintic, so the result is exact at every point (up to `f32`, and to the merging of breaks
/// closer than [`MIN_BREAK_S`]). `K2` must hold every
/// distinct shifted knot (at most the move's knots times the impulses).
pub fn shape<const K: usize, const K2: usize>(
    move_: &Spline<K>,
    shaper: &Shaper,
) -> Result<Spline<K2>, ShaperError> {
    shape_by(move_, &shaper.impulses()?)
}

/// [`shape`] by an impulse train of any origin (the last impulse's time the latest).
pub fn shape_by<const K: usize, const K2: usize>(
    move_: &Spline<K>,
    impulses: &Impulses,
) -> Result<Spline<K2>, ShaperError> {
    let mut all = [0.0f32; crate::knots::SHAPED_PLAN_KNOTS];
    let mut count = 0;
    for (_, ti) in impulses.iter() {
        for tk in move_.knot_times() {
            let slot =
                all.get_mut(count)
                    .ok_or(ShaperError::Spline(SplineError::TooManyKnots {
                        capacity: crate::knots::SHAPED_PLAN_KNOTS,
                    }))?;
            *slot = ti + tk;
            count += 1;
        }
    }
    let n = merge_breaks(all.get_mut(..count).unwrap_or(&mut []));
    if n > K2 {
        return Err(ShaperError::Spline(SplineError::TooManyKnots {
            capacity: K2,
        }));
    }
    let breaks = &all[..n];
    let mut points: heapless::Vec<(f32, f32, f32, f32), K2> = heapless::Vec::new();
    for (i, &t) in breaks.iter().enumerate() {
        let (mut p, mut v, mut a) = (0.0f32, 0.0f32, 0.0f32);
        for (amp, ti) in impulses.iter() {
            let r = move_.eval(t - ti);
            p += amp * r.pos;
            v += amp * r.vel;
            a += amp * r.acc;
        }
        let point = if i == 0 {
            (0.0, move_.start(), 0.0, 0.0)
        } else if i == n - 1 {
            (t, move_.end(), 0.0, 0.0)
        } else {
            (t, p, v, a)
        };
        // n <= K2, checked above.
        let _ = points.push(point);
    }
    Spline::try_from_states(&points).map_err(ShaperError::Spline)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn shaper(kind: ShaperKind, zeta: f32) -> Shaper {
        Shaper {
            kind,
            freq_hz: 7.0,
            damping: zeta,
            tolerance: 0.05,
        }
    }

    #[test]
    fn impulses_sum_to_one_and_cancel_their_mode() {
        for zeta in [0.0, 0.02, 0.1] {
            for kind in [ShaperKind::Zv, ShaperKind::Zvd] {
                // The train is worked out in f32: to a few of its steps (1.2e-7 near one,
                // 7e-9 s near the 71 ms half period).
                let imp = shaper(kind, zeta).impulses().unwrap();
                let sum: f64 = imp.iter().map(|(a, _)| a as f64).sum();
                assert!((sum - 1.0).abs() < 4.0 * f32::EPSILON as f64, "{sum}");
                // Zero vibration at the design frequency: an analytic property of ZV and ZVD
                // (the f32 amplitudes and times leave about 1e-7 per impulse).
                let residual = imp.residual(7.0, zeta as f64);
                assert!(residual < 1e-6, "{kind:?} {zeta}: {residual}");
                // Half a period between impulses, at the damped frequency.
                let td = 1.0 / (7.0 * (1.0 - (zeta as f64).powi(2)).sqrt());
                let t1 = imp.iter().nth(1).unwrap().1 as f64;
                assert!((t1 - td / 2.0).abs() < 3e-8, "{t1} against {}", td / 2.0);
            }
        }
    }

    #[test]
    fn zvd_tolerates_frequency_error_better_than_zv_and_ei_best() {
        // The ZVD's residual is flat at the design frequency (zero derivative); the EI keeps
        // within its tolerance over a wider band. At +-20 % the order is EI < ZVD < ZV.
        let r = |kind, f| shaper(kind, 0.0).impulses().unwrap().residual(f, 0.0);
        for f in [5.6, 8.4] {
            let (zv, zvd, ei) = (
                r(ShaperKind::Zv, f),
                r(ShaperKind::Zvd, f),
                r(ShaperKind::Ei, f),
            );
            assert!(ei < zvd && zvd < zv, "at {f} Hz: zv {zv} zvd {zvd} ei {ei}");
        }
        // EI leaves its tolerance at the design frequency when undamped (to the curve fit's
        // accuracy: its coefficients are rounded to five digits).
        assert!((r(ShaperKind::Ei, 7.0) - 0.05).abs() < 3e-3);
    }

    #[test]
    fn a_shaper_as_long_as_the_move_still_plans() {
        // ZVD at 5 Hz lasts 0.2 s: with a 0.2 s base move its last impulse starts exactly
        // where the first component ends (found by the CLI test, as "knot 3 is not later").
        let sh = Shaper {
            kind: ShaperKind::Zvd,
            freq_hz: 5.0,
            damping: 0.0,
            tolerance: 0.05,
        };
        let s = shaped_quintic::<8>(0.0, 0.5, 0.2, &sh, Timing::Stretch).unwrap();
        assert!((s.duration_s() - 0.4).abs() < 1e-6);
        assert!((s.eval(0.4).pos - 0.5).abs() < 1e-6);
    }

    #[test]
    fn bad_parameters_are_refused() {
        let s = |f, z, v| {
            Shaper {
                kind: ShaperKind::Ei,
                freq_hz: f,
                damping: z,
                tolerance: v,
            }
            .impulses()
            .unwrap_err()
        };
        assert_eq!(s(0.0, 0.0, 0.05), ShaperError::Frequency);
        assert_eq!(s(f32::NAN, 0.0, 0.05), ShaperError::Frequency);
        assert_eq!(s(7.0, 1.0, 0.05), ShaperError::Damping);
        assert_eq!(s(7.0, 0.0, 0.0), ShaperError::Tolerance);
        let long = shaper(ShaperKind::Zvd, 0.0);
        assert_eq!(
            shaped_quintic::<8>(0.0, 1.0, 0.1, &long, Timing::EndOnTime).unwrap_err(),
            ShaperError::TooLong
        );
    }

    #[test]
    fn a_shaped_move_is_the_sum_of_shifted_quintics() {
        for kind in [ShaperKind::Zv, ShaperKind::Zvd, ShaperKind::Ei] {
            let sh = shaper(kind, 0.03);
            let imp = sh.impulses().unwrap();
            for timing in [Timing::Stretch, Timing::EndOnTime] {
                let s = shaped_quintic::<8>(-1.5, 1.5, 0.35, &sh, timing).unwrap();
                let length = imp.duration_s() as f64;
                let base = match timing {
                    Timing::Stretch => 0.35,
                    Timing::EndOnTime => 0.35 - length,
                };
                let end = base + length;
                assert!((s.duration_s() as f64 - end).abs() < 1e-6);
                // Against the definition, evaluated independently with the unshaped quintic.
                let q = Spline::<2>::quintic(-1.5, 1.5, base as f32).unwrap();
                for k in 0..=200 {
                    let t = end * k as f64 / 200.0;
                    let mut want = (0.0, 0.0, 0.0);
                    for (a, ti) in imp.iter() {
                        let (a, ti) = (a as f64, ti as f64);
                        let r = q.eval((t - ti) as f32);
                        want.0 += a * r.pos as f64;
                        want.1 += a * r.vel as f64;
                        want.2 += a * r.acc as f64;
                    }
                    let got = s.eval(t as f32);
                    let tol = |x: f64| 1e-4 * (1.0 + x.abs());
                    assert!(
                        (got.pos as f64 - want.0).abs() < tol(want.0),
                        "{kind:?} pos at {t}"
                    );
                    assert!(
                        (got.vel as f64 - want.1).abs() < tol(want.1) * 10.0,
                        "{kind:?} vel at {t}"
                    );
                    assert!(
                        (got.acc as f64 - want.2).abs() < tol(want.2) * 100.0,
                        "{kind:?} acc at {t}"
                    );
                }
            }
        }
    }
}
