//! Cutting a raw log into its moves: where the hub turns, told from where it rests by the
//! encoder's own step (found in the log), with hysteresis, and split where it reverses.

use super::calibrate::REST_BEFORE_S;
use super::hub::encoder_step;
use beam_log::Log;

/// Pauses shorter than this inside a move (the hub slowing through a settling swing) do not
/// split it, s; a reversal of half the largest move does, whatever the pause
/// ([`split_moves`]).
pub const MOVE_GAP_S: f64 = 0.3;

/// Encoder steps a hub's angle may wander by, over the rate's +-10 ms window, and still be
/// at rest: a reading that flickers between two codes moves by one step, a hub ringing with
/// the beam after a move by a step or two more.
pub const REST_STEPS: f64 = 3.0;

/// The moves in `log`, each with the rest before it.
///
/// The hub's rate over +-10 ms marks motion where it passes the larger of 5 % of its peak
/// and [`REST_STEPS`] encoder steps over the window ([`encoder_step`]: a hub at rest whose
/// reading flickers by a step is at rest), and motion goes on until the rate falls below
/// half that (hysteresis). Runs of motion that pauses under [`MOVE_GAP_S`] do not break are
/// joined; a run is then split where the hub reverses
/// after travelling at least half the largest move each way (a step up straight after a
/// step down), and runs covering less than a tenth of the largest are dropped. With one
/// move (or none), the log whole. Each cut runs from twice [`REST_BEFORE_S`] before its
/// move's fast part, or the previous move's end if nearer, to as much before the next move
/// (or the log's end).
pub fn split_moves(log: &Log) -> Vec<Log> {
    let n = log.t.len();
    let whole = || vec![log.clone()];
    if n < 3 {
        return whole();
    }
    let dt = (log.t[n - 1] - log.t[0]) / (n - 1) as f64;
    let w = ((0.01 / dt).round() as usize).max(1);
    let rate: Vec<f64> = (0..n)
        .map(|k| {
            let (a, b) = (k.saturating_sub(w), (k + w).min(n - 1));
            (log.theta[b] - log.theta[a]) / ((b - a) as f64 * dt)
        })
        .collect();
    let peak = rate.iter().fold(0.0f64, |m, r| m.max(r.abs()));
    if !(peak > 0.0) {
        return whole();
    }
    let quantum = encoder_step(&log.theta).map_or(0.0, |s| REST_STEPS * s / (2.0 * w as f64 * dt));
    let high = (0.05 * peak).max(quantum);
    let low = 0.5 * high;
    // Runs of motion, with hysteresis, and the direction of each.
    let mut runs: Vec<(usize, usize)> = vec![];
    let mut moving = false;
    for (k, r) in rate.iter().enumerate() {
        moving = if moving {
            r.abs() > low
        } else {
            r.abs() > high
        };
        if moving {
            match runs.last_mut() {
                Some(run) if run.1 + 1 == k => run.1 = k,
                _ => runs.push((k, k)),
            }
        }
    }
    // Pauses under MOVE_GAP_S joined (a move's settling swings stay with it), then split
    // again where the hub really turned back.
    let gap = (MOVE_GAP_S / dt).round() as usize;
    let mut joined: Vec<(usize, usize)> = vec![];
    for r in runs {
        match joined.last_mut() {
            Some(last) if r.0 <= last.1 + gap => last.1 = r.1,
            _ => joined.push(r),
        }
    }
    let mut runs = split_reversals(&log.theta, joined);
    let travel = |r: &(usize, usize)| (log.theta[r.1] - log.theta[r.0]).abs();
    let largest = runs.iter().map(travel).fold(0.0f64, f64::max);
    runs.retain(|r| travel(r) >= 0.1 * largest);
    if runs.len() < 2 {
        return whole();
    }
    let rest = (2.0 * REST_BEFORE_S / dt).round() as usize;
    runs.iter()
        .enumerate()
        .map(|(i, &(start, _))| {
            let prev_end = if i == 0 { 0 } else { runs[i - 1].1 };
            let from = start.saturating_sub(rest).max(prev_end);
            let to = match runs.get(i + 1) {
                Some(&(next, _)) => next.saturating_sub(rest).max(runs[i].1 + 1),
                None => n,
            };
            log.slice(from..to.min(n))
        })
        .collect()
}

/// `runs` with each split where the hub turns back after travelling at least half the
/// largest run's travel each way (a step straight after a step the other way; a move's
/// overshoot and settling swings are far smaller): at the turning point's sample.
fn split_reversals(theta: &[f64], runs: Vec<(usize, usize)>) -> Vec<(usize, usize)> {
    let largest = runs
        .iter()
        .map(|r| (theta[r.1] - theta[r.0]).abs())
        .fold(0.0f64, f64::max);
    let least = 0.5 * largest;
    let mut out = vec![];
    for (start, end) in runs {
        let mut from = start;
        // The extreme reached so far from `from`, and whether the hub has come back from
        // it by `least` (then the run splits there).
        let mut extreme = from;
        for k in start..=end {
            let gone = theta[extreme] - theta[from];
            let (ahead, back) = (theta[k] - theta[from], theta[k] - theta[extreme]);
            if ahead.abs() > gone.abs() {
                extreme = k;
            } else if gone.abs() >= least && back.abs() >= least && back.signum() != gone.signum() {
                out.push((from, extreme));
                from = extreme;
                extreme = k;
            }
        }
        out.push((from, end));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use beam_log::BeamSensor;

    /// A log like a second rig's: 1 kHz, the hub angle read with 0.3 mrad of noise about
    /// a code's boundary and rounded to 1 mrad (so at rest it flickers between two codes), a smooth step of
    /// `amplitude` rad over 0.2 s at each of `steps` (start time, sign), each followed by a
    /// 1.8 Hz ring of the hub of 2 mrad decaying with a 0.5 s time constant.
    fn rig_log(seconds: f64, steps: &[(f64, f64)], amplitude: f64) -> Log {
        let n = (seconds * 1000.0) as usize;
        let t: Vec<f64> = (0..n).map(|k| k as f64 * 1e-3).collect();
        let theta: Vec<f64> = t
            .iter()
            .enumerate()
            .map(|(k, &t)| {
                // Uniform in +-0.5 mrad (0.29 mrad RMS), from a fixed integer hash.
                let hash = (k as u32).wrapping_mul(2_654_435_761) >> 8;
                // About a code's boundary (0.45 mrad), so that a hub at rest flickers.
                let noise = 0.45e-3 + (hash as f64 / (1u32 << 24) as f64 - 0.5) * 1e-3;
                let steps: f64 = steps
                    .iter()
                    .map(|&(at, sign)| {
                        let s = ((t - at) / 0.2).clamp(0.0, 1.0);
                        let ramp = 0.5 - 0.5 * (std::f64::consts::PI * s).cos();
                        let after = t - at - 0.2;
                        let ring = if after > 0.0 {
                            0.002
                                * (-after / 0.5).exp()
                                * (2.0 * std::f64::consts::PI * 1.8 * after).sin()
                        } else {
                            0.0
                        };
                        sign * (amplitude * ramp + ring)
                    })
                    .sum();
                ((noise + steps) * 1000.0).round() / 1000.0
            })
            .collect();
        Log {
            torque: vec![0.0; n],
            beam_signal: vec![0.0; n],
            sensor: BeamSensor::TipDeflection,
            mid_strain: None,
            t,
            theta,
        }
    }

    /// Each cut's net travel, rad.
    fn travels(cuts: &[Log]) -> Vec<f64> {
        cuts.iter()
            .map(|c| c.theta[c.theta.len() - 1] - c.theta[0])
            .collect()
    }

    #[test]
    fn the_step_of_the_rounded_angle_is_found() {
        let log = rig_log(4.0, &[(1.0, 1.0)], 0.1);
        let step = encoder_step(&log.theta).unwrap();
        assert!((step - 1e-3).abs() < 1e-9, "{step}");
    }

    #[test]
    fn a_step_up_and_a_step_down_with_seconds_of_rest_are_two_moves() {
        // The second rig's log: 10 s, +-0.1 rad, rests of seconds, 1 mrad rounding.
        let log = rig_log(10.0, &[(2.0, 1.0), (6.0, -1.0)], 0.1);
        let cuts = split_moves(&log);
        let t = travels(&cuts);
        assert_eq!(cuts.len(), 2, "{t:?}");
        assert!(
            (t[0] - 0.1).abs() < 0.01 && (t[1] + 0.1).abs() < 0.01,
            "{t:?}"
        );
        // Each cut holds its move whole, with the rest before it.
        assert!(cuts[0].t[0] <= 2.0 - REST_BEFORE_S && cuts[0].t[cuts[0].t.len() - 1] > 2.5);
        assert!(cuts[1].t[0] <= 6.0 - REST_BEFORE_S && cuts[1].t[cuts[1].t.len() - 1] > 6.5);
    }

    #[test]
    fn steps_with_short_rests_between_them_are_split_at_each_reversal() {
        // Up, down, up with 0.1 s between them: under MOVE_GAP_S, but the hub turns back.
        let log = rig_log(3.0, &[(0.5, 1.0), (0.8, -1.0), (1.1, 1.0)], 0.1);
        let t = travels(&split_moves(&log));
        assert_eq!(t.len(), 3, "{t:?}");
        assert!(t[0] > 0.08 && t[1] < -0.08 && t[2] > 0.08, "{t:?}");
    }
}
