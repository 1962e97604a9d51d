//! LQR with integral action on a steady-state Kalman observer of the hub and the flexible
//! modes (encoder, root strain and torque in), with rigid-body feedforward: the torque sees
//! the modes, so the loop damps the beam. The design (`beam_model::lqg`) needs a whole modal
//! model, so the law is built on the host only, behind model-core's `observer` feature.

#[cfg(feature = "observer")]
use super::integrate;
use super::{gains, ControlLaw, Estimate, LawGains, LawPlant, LawState};
use crate::beam::ParamError;
#[cfg(feature = "observer")]
use crate::beam::ParamErrorKind;
use crate::plant::PlantPoint;
use crate::spline::RefPoint;
#[cfg(feature = "observer")]
use beam_model::lqg::{LqgDesign, LqgError, LqgWeights, DESIGN_MODES, MAX_STATES};

gains! {
    /// LQG weights (`beam_model::lqg::LqgWeights` in `f32`): the state feedback with
    /// integral action and the Kalman observer are designed from them and the plant when the
    /// law is built on a modal model ([`ControlLaw::try_build`]).
    pub struct LqgGains for Lqg {
        /// Hub angle weight as a stiffness, N m/rad.
        kp,
        /// Hub rate weight, N m s/rad.
        kd,
        /// Integral weight, N m/(rad s).
        ki,
        /// Weight on the beam's vibration energy, (N m)^2/J.
        kq,
        /// Disturbance torque the observer assumes, N m.
        sigma,
    }
}

#[cfg(feature = "observer")]
impl LqgGains {
    /// The design's weights, with a regulator of degree of stability `move_rate` (1/s, 0 for
    /// none) while the reference moves and the encoder read at rest as its count's interval
    /// if `count_interval` (`beam_model::lqg::LqgWeights`).
    pub fn weights(&self, move_rate: f64, count_interval: bool) -> LqgWeights {
        LqgWeights {
            kp: self.kp as f64,
            kd: self.kd as f64,
            ki: self.ki as f64,
            kq: self.kq as f64,
            sigma_nm: self.sigma as f64,
            move_rate,
            count_interval,
        }
    }

    /// The law designed on `plant` from these weights and the two options of
    /// [`LqgGains::weights`].
    pub(super) fn build_with(
        &self,
        plain: ControlLaw,
        plant: &impl LawPlant,
        move_rate: f64,
        count_interval: bool,
    ) -> Result<ControlLaw, ParamError> {
        let weights = self.weights(move_rate, count_interval);
        let design = plant
            .lqg(&weights, crate::DEFAULT_TS_S as f64)
            .ok_or(ParamError {
                field: "lqg",
                kind: ParamErrorKind::NeedsModel,
            })?
            .map_err(|e| ParamError {
                field: "lqg",
                kind: match e {
                    LqgError::Weights => ParamErrorKind::OutOfRange,
                    LqgError::Numerics | LqgError::Modes => ParamErrorKind::NoDesign,
                },
            })?;
        // |Ki z| within the limit: the integral cannot wind up past what it can use.
        let ki = libm::fabsf(design.ki);
        Ok(ControlLaw {
            integral_max: if ki > 0.0 {
                design.torque_limit_nm / ki
            } else {
                0.0
            },
            observer: design,
            ..plain
        })
    }
}

/// Flexible modes the LQG law observes and controls: the first two (see `LawPlant::lqg`).
pub const LQG_MODES: usize = beam_model::lqg::DESIGN_MODES;

/// The noise the LQG observer assumes on the root strain gauge, strain: a bridge amplifier's
/// typical floor, well above a 24-bit converter's quantisation. 0.6 ue, a little above the
/// simulated gauge's 0.5 ue, chosen with [`TORQUE_LOWPASS_HZ`] by sweeps of 200 beams 20 %
/// off the model on two seeds (docs/results.md). At 1 ue the observer leaned on the encoder
/// and left the short moves' strain at the 5 ue band's edge on beams stiffer than the model
/// (15 deg p95 2.9 s against 1.1 s); at 0.6 ue without the low-pass, its torque at rest
/// carried 0.5 N m RMS of noise.
pub const ASSUMED_STRAIN_NOISE: f64 = 0.6e-6;

/// The LQG law's state between ticks.
#[cfg(feature = "observer")]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ObserverState {
    /// The observer's state estimate, in [`LqgDesign`]'s layout.
    pub estimate: [f32; MAX_STATES],
    /// The reference beam's modes and rates, see [`LqgDesign::ref_ad`].
    pub reference: [f32; 2 * DESIGN_MODES],
    /// The torque the drive applied last tick, within the limit, N m.
    pub applied_nm: f32,
    /// How far the encoder reads from what the observer predicted it would, rad: the
    /// innovation's magnitude, low-passed over ten ticks.
    pub residual_theta: f32,
    /// How far the root gauge reads from the observer's prediction, strain, low-passed
    /// likewise.
    pub residual_strain: f32,
    /// The root strain of the observer's estimate of the beam (its modes), strain: what the
    /// beam is doing whatever the gauge says.
    pub strain_estimate: f32,
    /// The observer has been started from the measured hub angle. While false, the rest of
    /// this state is as [`Default`] made it (a new or restarted [`LawState`]), and the next
    /// tick only sets the angle.
    pub(crate) observing: bool,
    /// How much of the moving regulator ([`LqgDesign::k_move`]) the feedback carries: 1 while
    /// the reference moves, then fading over [`MOVE_FADE_S`]; 0 before the first move.
    pub move_weight: f32,
}

/// How long the moving regulator ([`LqgDesign::k_move`]) fades over once the reference is at
/// rest, s (the time constant): long enough to damp what the move left, short enough that
/// the quieter regulator holds the beam in its band against the sensors' noise. Chosen by
/// sweeps over 200 beams on seven seeds (docs/results.md): 0.45 s gave a shorter p95 than
/// 0.1-0.35 s at every length, 0.6-1 s left a beam unsettled on some seeds.
#[cfg(feature = "observer")]
pub const MOVE_FADE_S: f32 = 0.45;

/// The fade's factor per tick at the drive's 1 kHz, `exp(-ts / MOVE_FADE_S)` (a test checks
/// it).
#[cfg(feature = "observer")]
pub const MOVE_FADE_PER_TICK: f32 = 0.997_780_24;

/// The span of the residuals' low-pass, ticks: a fault that lasts a tenth of this is seen,
/// one tick of noise is averaged away.
#[cfg(feature = "observer")]
pub const RESIDUAL_TICKS: f32 = 10.0;

/// An all-zero design, for the laws without an observer.
#[cfg(feature = "observer")]
pub(super) const NO_OBSERVER: LqgDesign = LqgDesign::ZERO;

impl LawGains for LqgGains {
    /// The shipped rows' weights: a hub stiffness weight of 200 N m/rad, a rate weight of
    /// 1 N m s/rad, an integral weight of 1000, the beam's vibration energy weighted at 1e4
    /// and a 1.75 N m disturbance for the observer. Chosen by sweeps over beams 20 % off the
    /// model on two seeds (docs/results.md), with the reference beam swung by the torque:
    /// stiffer weights settle a nominal beam sooner but lose beams whose first mode is off
    /// the model's, and an observer that assumes less disturbance follows a beam off the
    /// model too slowly (at 1 N m, 3 of 200 soft, heavy beams went past the strain trip at
    /// 180 deg).
    const START: Self = LqgGains {
        kp: 200.0,
        kd: 1.0,
        ki: 1000.0,
        kq: 10000.0,
        sigma: 1.75,
    };

    /// The LQG law bends a reference beam through the move. When it held the reference
    /// beam's hub on the reference, its feedforward for a base move much shorter than the
    /// first period passed the limit (15 deg in 0.083 s, 0.45 periods of the aluminium beam:
    /// 6-10 N m, settled in 0.98 s; in 0.12 s, 0.66 periods: 1.9 N m, 0.61 s). Its
    /// feedforward is now the rigid body's, which the planner holds within the limit, but
    /// the floor still pays: without it the 15 deg p95 over 200 drawn beams was 1.53 s
    /// against 1.10 s (docs/results.md). The other laws leave the beam to the shaper and are
    /// fastest at the torque-limited time.
    const MIN_MOVE_PERIODS: f32 = 0.66;

    /// The design on `plant`; refused on a plant that cannot design one (a [`PlantPoint`])
    /// and without the `observer` feature. One regulator throughout, and the encoder read as
    /// a point: smc-modal's faster regulator while moving shortened this law's p95 on short
    /// moves but lengthened it at 90-180 deg and broke beams down, and the count's interval
    /// at rest lost beams (its integral holds the hub by the sub-count estimate;
    /// docs/results.md).
    fn build(
        &self,
        plain: ControlLaw,
        _: &PlantPoint,
        plant: &impl LawPlant,
    ) -> Result<ControlLaw, ParamError> {
        #[cfg(feature = "observer")]
        {
            self.build_with(plain, plant, 0.0, false)
        }
        #[cfg(not(feature = "observer"))]
        {
            let _ = (plain, plant);
            Err(ParamError {
                field: "lqg",
                kind: crate::beam::ParamErrorKind::NeedsModel,
            })
        }
    }

    #[inline(always)]
    fn torque_nm(
        &self,
        law: &ControlLaw,
        x: &Estimate,
        r: &RefPoint,
        state: &mut LawState,
        ts_s: f32,
    ) -> f32 {
        #[cfg(feature = "observer")]
        {
            lqg_torque(law, x, r, state, ts_s)
        }
        // Never built without the feature (`build` refuses it).
        #[cfg(not(feature = "observer"))]
        {
            let _ = (law, x, r, state, ts_s);
            0.0
        }
    }
}

/// The reference rate above which the LQG law's integral holds its value, rad/s: a quarter
/// of the planner's 20 rad/s. The integral is there for what stays (friction, a load); at
/// speed the hub's error is the move's (a beam heavier than the model lags it), and
/// integrating it wound the integral up: on 200 beams 20 % off the model (`--seed 2`), one
/// soft, heavy beam was bent past the trip at 180 deg. Held above this rate, none was, and
/// the p95 moved by under 0.1 s at 15-180 deg (docs/results.md).
pub const INTEGRAL_MAX_RATE_RAD_S: f32 = 5.0;

/// The LQG tick: [`observe`], then the integral (below [`INTEGRAL_MAX_RATE_RAD_S`]). Fixed loops over the whole layout: no bound
/// is read at run time.
#[cfg(feature = "observer")]
#[inline(always)]
fn lqg_torque(this: &ControlLaw, x: &Estimate, r: &RefPoint, law: &mut LawState, ts_s: f32) -> f32 {
    let (mut u, _, pos) = observe(this, x, r, law);
    if libm::fabsf(r.vel) < INTEGRAL_MAX_RATE_RAD_S {
        law.integral = integrate(
            law.integral,
            law.lqg.estimate[0] - pos,
            ts_s,
            this.integral_max,
        );
    }
    u -= this.observer.ki * law.integral;
    applied(law, u, this.observer.torque_limit_nm)
}

/// Index of the hub rate in [`LqgDesign`]'s layout.
#[cfg(feature = "observer")]
pub(super) const RATE: usize = 1 + DESIGN_MODES;
// `observe` is written out for this layout.
#[cfg(feature = "observer")]
const _: () = assert!(DESIGN_MODES == 2 && RATE == 3 && MAX_STATES == 6);

/// `[body(i0), body(i1), ...]`, each written out with `i` a constant, in order (the body
/// may update running sums). See `dot!` for why.
#[cfg(feature = "observer")]
macro_rules! unrolled {
    ($i:ident in [$($n:literal)*] => $body:block) => {
        [$({
            #[allow(non_upper_case_globals)]
            const $i: usize = $n;
            $body
        }),*]
    };
}

/// `init + a[0] x[0] + a[1] x[1] + ...`, written out and summed left to right, as the
/// loops it replaces summed: the drive and the host round alike, and at the drive's
/// `opt-level = "z"` a loop or an iterator chain is not unrolled (measured: the observer's
/// iterator loops cost three times their multiply-adds).
#[cfg(feature = "observer")]
macro_rules! dot {
    ($name:ident, $n:literal, $($i:literal)*) => {
        #[inline(always)]
        fn $name(init: f32, a: &[f32; $n], x: &[f32; $n]) -> f32 {
            init $(+ a[$i] * x[$i])*
        }
    };
}
#[cfg(feature = "observer")]
dot!(dot2, 2, 0 1);
#[cfg(feature = "observer")]
dot!(dot4, 4, 0 1 2 3);
#[cfg(feature = "observer")]
dot!(dot5, 5, 0 1 2 3 4);

/// The observer's tick, shared by the laws on it: its predict (with the torque applied last
/// tick) and update (with the hub angle and root strain), the reference beam's step, and
/// the state feedback about the reference state (the hub on its reference, the beam bent as
/// the reference's torque swings it). Returns `(ff - K (x - x_ref), K (x - x_ref),
/// theta_ref)`: the feedforward less the state feedback and the feedback alone, N m, and
/// the reference state's hub angle, rad.
///
/// Written out for [`DESIGN_MODES`] = 2 (the layout `[theta, q0, q1, theta', q0', q1']`): a
/// design with another number of modes does not compile here.
#[cfg(feature = "observer")]
#[inline(always)]
pub(super) fn observe(
    this: &ControlLaw,
    x: &Estimate,
    r: &RefPoint,
    law: &mut LawState,
) -> (f32, f32, f32) {
    let d = &this.observer;
    let state = &mut law.lqg;
    if !state.observing {
        // From rest at the measured angle: a move starts with the hub still. The rest of the
        // state was cleared when the move was armed (`LawState::restart`), off the tick.
        state.estimate[0] = x.theta;
        state.observing = true;
    }
    // Each row is written out (`unrolled!`, `dot5`): a closure or a loop here is a call or
    // a loop at the drive's `opt-level = "z"`, reloading the state each time. Each value is
    // made just before it is used and stored as soon as it is made, so that the state stays
    // in the FPU's registers instead of spilling to the stack.
    //
    // The reference beam at this tick, the reference state's hub (the rigid reference
    // turned by the beam swinging on it), the feedforward, and the reference beam's next
    // state.
    let rb = state.reference;
    let (rq, rdq) = ([rb[0], rb[1]], [rb[2], rb[3]]);
    let pos = dot2(r.pos, &d.ref_hub, &rq);
    let vel = dot2(r.vel, &d.ref_hub, &rdq);
    // The hub rate squared: the centrifugal term (minus the foreshortening) of the
    // reference beam, `Mf^-1 S w^2 q` in the modes' equations.
    let w2 = vel * vel;
    let u = d.mtt * r.acc + d.viscous * vel;
    // Made here, not where the branch below merges: left to itself, LLVM loads these
    // coefficients now, spills them to the stack over the reference beam's step and adds
    // them up after it (about 30 instructions of the drive's tick). `black_box` pins the
    // sum to this point for 3 (a store and a load); the value is unchanged.
    let mut u = core::hint::black_box(u);
    // Once the reference is at rest the reference beam is too: whatever it would still
    // ring with (a shaper's residual, a mode it was not tuned for) is the feedback's to
    // damp, not to follow. (A move through waypoints that stops at one for a tick resets
    // it there too; the law cannot tell that pause from the end.)
    // Each row is stored as it is made (an array made first is stored and copied).
    let at_rest = r.vel == 0.0 && r.acc == 0.0;
    if at_rest {
        state.reference = [0.0; 2 * DESIGN_MODES];
        state.move_weight *= MOVE_FADE_PER_TICK;
    } else {
        state.move_weight = 1.0;
        unrolled!(i in [0 1 2 3] => {
            let z = dot4(d.ref_bd[i] * r.acc, &d.ref_ad[i], &rb);
            state.reference[i] = if i < DESIGN_MODES {
                z
            } else {
                z + w2 * dot2(0.0, &d.ref_s[i - DESIGN_MODES], &rq)
            };
        });
    }
    // The prediction, from the torque applied last tick; the innovations need the angle's
    // and the modes' rows first.
    let xo = state.estimate;
    let u_last = state.applied_nm;
    // The sampled matrix's angle column is `[1, 0, ..]` (`LqgDesign::ad`): the angle's row
    // adds the angle, the others skip it. (`1 * x` is `x` and `0 * x` adds nothing, so the
    // sums round as the whole rows did, up to the sign of a sum that is exactly zero.)
    let xt = [xo[1], xo[2], xo[3], xo[4], xo[5]];
    let head = unrolled!(i in [0 1 2] => {
        let init = d.bd[i] * u_last;
        dot5(if i == 0 { init + xo[0] } else { init }, &d.ad[i], &xt)
    });
    // At rest the reading says the hub is within its count, `[theta + lo, theta + hi]`
    // (`LqgDesign::count_interval`): the angle is corrected only by how far the prediction
    // lies outside it. Read as a noisy point, a hub still between two counts toggles the
    // estimate a count's width each time the reading flips, and the torque that follows
    // keeps the beam ringing (0.7 ue RMS on the model, 2 ue on beams off it). While the
    // reference moves the point is read as it is.
    let innov_theta = {
        let e = x.theta - head[0];
        let [lo, hi] = d.count_interval;
        if !at_rest || libm::fabsf(e) > 2.0 * (hi - lo) {
            e
        } else if e + lo > 0.0 {
            e + lo
        } else if e + hi < 0.0 {
            e + hi
        } else {
            0.0
        }
    };
    let innov_strain = x.strain - d.strain_coef[0] * head[1] - d.strain_coef[1] * head[2];
    // What each sensor says against what the observer expected it to say (the drive's
    // sensor monitor reads these, `Controller::step_in`).
    const K: f32 = 1.0 / RESIDUAL_TICKS;
    state.residual_theta += K * (libm::fabsf(innov_theta) - state.residual_theta);
    state.residual_strain += K * (libm::fabsf(innov_strain) - state.residual_strain);
    let w2_est = xo[RATE] * xo[RATE];
    let q_est = [xo[1], xo[2]];
    // The update, and the state the feedback holds it to: the hub on its reference, the
    // beam as the reference beam is.
    let reference = [pos, rq[0], rq[1], vel, rdq[0], rdq[1]];
    let w = state.move_weight;
    let mut sigma = 0.0f32;
    macro_rules! update {
        ($i:ident, $pred:expr) => {{
            let xi = $pred + d.l[$i][0] * innov_theta + d.l[$i][1] * innov_strain;
            let feedback = (d.k[$i] + w * d.k_move[$i]) * (xi - reference[$i]);
            u -= feedback;
            sigma += feedback;
            state.estimate[$i] = xi;
        }};
    }
    unrolled!(i in [0 1 2] => { update!(i, head[i]) });
    // The rates' rows, with the centrifugal term at the estimated hub rate.
    unrolled!(i in [3 4 5] => {
        update!(
            i,
            dot5(d.bd[i] * u_last, &d.ad[i], &xt) + w2_est * dot2(0.0, &d.obs_s[i - RATE], &q_est)
        )
    });
    state.strain_estimate =
        d.strain_coef[0] * state.estimate[1] + d.strain_coef[1] * state.estimate[2];
    (u, sigma, pos)
}

/// The corner of the first-order low-pass on the observer laws' torque, Hz. The estimate
/// carries the encoder's steps and the gauge's noise straight into the torque (the update's
/// gain times the feedback's): at rest 0.31-0.40 N m RMS, most of it above 150 Hz, where the
/// beam's first two modes (4-6 and 30-40 Hz) have no use for it. At 200 Hz the filter lags
/// 10 deg at the second mode; at 100 Hz the lag cost more settle time than the noise did
/// (docs/results.md).
pub const TORQUE_LOWPASS_HZ: f32 = 201.9;

/// The low-pass's step at the drive's 1 kHz tick, `1 - exp(-2 pi f ts)` for
/// [`TORQUE_LOWPASS_HZ`] (a test checks it): 23/32, a value the FPU loads as an immediate.
/// A literal would cost the 4 bytes of flash the smc-modal board does not have.
pub const TORQUE_LOWPASS_ALPHA: f32 = 0.718_75;

/// Low-passes `u` ([`TORQUE_LOWPASS_HZ`]) from the torque applied last tick, records the
/// result within the drive's `limit` as the torque the observer is told was applied next
/// tick, and returns it.
#[cfg(feature = "observer")]
#[inline(always)]
pub(super) fn applied(law: &mut LawState, u: f32, limit: f32) -> f32 {
    // The filter's state is the torque applied last tick: within the limit, so a saturated
    // command does not wind the filter up.
    let last = law.lqg.applied_nm;
    let u = last + TORQUE_LOWPASS_ALPHA * (u - last);
    law.lqg.applied_nm = if u > limit {
        limit
    } else if u < -limit {
        -limit
    } else {
        u
    };
    u
}
