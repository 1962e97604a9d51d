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
    /// What the LQG law adds to its weights: the beam's stiffness identified at the start of
    /// each move, as smc-modal's, for its observer alone (its feedback holds the beam to the
    /// reference beam as the model bends it: the identifier reads a payload's beam as
    /// softer, 9 % at 50 g, and taking that into the reference stopped the nominal 180 deg
    /// move at 25 and 50 g 1.1 and 1.3 s after the command, against 0.80 and 0.93 s). One
    /// regulator throughout, and the encoder read as a point: smc-modal's faster regulator
    /// while moving shortened this law's p95 on short moves but lengthened it at 90-180 deg
    /// and broke beams down, and the count's interval at rest lost beams (its integral holds
    /// the hub by the sub-count estimate; docs/results.md).
    ///
    /// Without the identifier, the linear analysis of the sampled loop
    /// (`beam_model::lqg::loop_radius`) found the loop at rest unstable on a beam 20 %
    /// stiffer and lighter than the model (its first mode 22 % above the observer's; on the
    /// nonlinear plant the torque's noise grew from 0.13 to 1.3 N m RMS over 3 s); with it,
    /// the observer runs on the beam's stiffness once found, and its p95 over 200 beams is
    /// 0.13-0.21 s shorter at 15-180 deg (docs/results.md).
    pub const DESIGN_OPTIONS: DesignOptions = DesignOptions {
        move_rate: 0.0,
        move_rate_unloaded: 0.0,
        move_rate_payload_kg: 0.0,
        rest_kp_factor: 0.0,
        count_interval: false,
        identify: true,
    };

    /// The design's weights with `options` (`beam_model::lqg::LqgWeights`).
    pub fn weights(&self, options: DesignOptions) -> LqgWeights {
        LqgWeights {
            kp: self.kp as f64,
            kd: self.kd as f64,
            ki: self.ki as f64,
            kq: self.kq as f64,
            sigma_nm: self.sigma as f64,
            move_rate: options.move_rate,
            move_rate_unloaded: options.move_rate_unloaded,
            move_rate_payload_kg: options.move_rate_payload_kg,
            rest_kp: self.kp as f64 * options.rest_kp_factor,
            count_interval: options.count_interval,
            identify: options.identify,
            feedback_lowpass: FEEDBACK_LOWPASS_ALPHA as f64,
        }
    }

    /// The law designed on `plant` from these weights with `options`.
    pub(super) fn build_with(
        &self,
        plain: ControlLaw,
        plant: &impl LawPlant,
        options: DesignOptions,
    ) -> Result<ControlLaw, ParamError> {
        let weights = self.weights(options);
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

/// What a law on the LQG design adds to the weights (`beam_model::lqg::LqgWeights`).
#[cfg(feature = "observer")]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct DesignOptions {
    /// A regulator of this degree of stability while the reference moves, 1/s (0: none).
    pub move_rate: f64,
    /// The moving regulator's rate without a payload, falling to `move_rate` at
    /// `move_rate_payload_kg` (`beam_model::lqg::LqgWeights::move_rate_unloaded`; 0: none).
    pub move_rate_unloaded: f64,
    /// The payload from which the moving regulator's rate is `move_rate`, kg.
    pub move_rate_payload_kg: f64,
    /// With a moving regulator, the regulator at rest designed on `kp` times this
    /// (`beam_model::lqg::LqgWeights::rest_kp`; 0: on `kp`).
    pub rest_kp_factor: f64,
    /// The encoder read at rest as its count's interval.
    pub count_interval: bool,
    /// The beam's stiffness identified at the start of each move (with the `identify`
    /// feature; `LqgDesign::id_a`).
    pub identify: bool,
}

/// Flexible modes the LQG law observes and controls: the first two (see `LawPlant::lqg`).
pub const LQG_MODES: usize = beam_model::lqg::DESIGN_MODES;

/// The noise the LQG observer assumes on the root strain gauge, strain: a bridge amplifier's
/// typical floor, well above a 24-bit converter's quantisation. 0.6 ue, a little above the
/// simulated gauge's 0.5 ue, chosen with a 202 Hz low-pass on the torque (since replaced by
/// [`FEEDBACK_LOWPASS_HZ`]) by sweeps of 200 beams 20 % off the model on two seeds
/// (docs/results.md). At 1 ue the observer leaned on the encoder
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
    /// The feedback low-pass's state ([`FEEDBACK_LOWPASS_HZ`]): the feedback in the torque
    /// applied last tick (that torque less its feedforward), N m.
    pub feedback_nm: f32,
    /// How far the encoder reads from what the observer predicted it would, rad: the
    /// innovation's magnitude, low-passed over ten ticks.
    pub residual_theta: f32,
    /// How far the root gauge reads from the observer's prediction, strain, low-passed
    /// likewise; each tick at rest on which the torque swings to a limit from the other side
    /// of zero adds [`RING_STEP`] (the loop ringing through the gauge).
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
    /// The torque swung to a limit from the other side of zero at rest this move
    /// ([`RING_STEP`]): a gauge residual past its bound is then the loop ringing, not the
    /// gauge failing.
    pub rang: bool,
    /// What the identifier found of the beam this move, and its state.
    #[cfg(feature = "identify")]
    pub adaptation: Adaptation,
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
    /// and a 2 N m disturbance for the observer. Chosen by sweeps over beams 20 % off the
    /// model on two seeds (docs/results.md), with the reference beam swung by the torque:
    /// stiffer weights settle a nominal beam sooner but lose beams whose first mode is off
    /// the model's, and an observer that assumes less disturbance follows a beam off the
    /// model too slowly (at 1 N m, 3 of 200 soft, heavy beams went past the strain trip at
    /// 180 deg). 1.75 N m until the law identified the beam's stiffness
    /// (`LqgGains::DESIGN_OPTIONS`): by the linear analysis of the sampled loop
    /// (`beam_model::lqg::loop_radius`) a beam 20 % stiffer and lighter, with a hub 20 %
    /// lighter, still grew at rest on four modes (5.5 1/s) with the stiffness identified;
    /// at 2 N m no beam at the spread's corners does.
    const START: Self = LqgGains {
        kp: 200.0,
        kd: 1.0,
        ki: 1000.0,
        kq: 10000.0,
        sigma: 2.0,
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

    /// 1500 ue, as smc-modal's: with the beam's stiffness identified the observer follows a
    /// soft, heavy beam more closely and the feedback bends it further, to 2020-2051 ue at
    /// 180 deg over six of seven sets of 200 beams without a budget (1952-1984 on the
    /// seventh); with it 1760-1825 ue.
    const PLANNED_STRAIN: f32 = 1.5e-3;

    /// The design on `plant` with `LqgGains::DESIGN_OPTIONS`; refused on a plant that
    /// cannot design one (a [`PlantPoint`]) and without the `observer` feature.
    fn build(
        &self,
        plain: ControlLaw,
        _: &PlantPoint,
        plant: &impl LawPlant,
    ) -> Result<ControlLaw, ParamError> {
        #[cfg(feature = "observer")]
        {
            self.build_with(plain, plant, Self::DESIGN_OPTIONS)
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
    let (ff, feedback, pos) = observe::<{ cfg!(feature = "identify") }, false>(this, x, r, law);
    if libm::fabsf(r.vel) < INTEGRAL_MAX_RATE_RAD_S {
        law.integral = integrate(
            law.integral,
            law.lqg.estimate[0] - pos,
            ts_s,
            this.integral_max,
        );
    }
    let feedback = feedback + this.observer.ki * law.integral;
    applied(law, ff, feedback, this.observer.torque_limit_nm)
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
/// iterator loops cost three times their multiply-adds). A plain dot product starts from
/// -0.0, not 0.0: `-0.0 + y` is `y` for every `y`, so the compiler drops the add, where
/// `0.0 + y` (which turns -0.0 into 0.0) is an add (seven of them in the observer laws'
/// tick).
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

// After the macros above, which it uses.
#[cfg(feature = "identify")]
pub(super) mod identify;
#[cfg(feature = "identify")]
use identify::{adapt, softer, stiffer};
#[cfg(feature = "identify")]
pub use identify::{
    clamped_coupling, Adaptation, Identifier, COMPLIANCE_BLEND_PER_TICK, COMPLIANCE_FADE_STRAIN,
    IDENTIFY_DEAD_BAND, IDENTIFY_RANGE, IDENTIFY_TICKS,
};

/// The observer's tick, shared by the laws on it: its predict (with the torque applied last
/// tick) and update (with the hub angle and root strain), the reference beam's step, and
/// the state feedback about the reference state (the hub on its reference, the beam bent as
/// the reference's torque swings it) and on the feedback low-pass's state `f`
/// ([`LqgDesign::k_filter`]). Returns `(ff, K (x - x_ref) + kf f, theta_ref)`: the
/// feedforward and the state feedback, N m (the torque asked for is `ff` less the
/// feedback), and the reference state's hub angle, rad.
///
/// With `IDENTIFY` (and the `identify` feature), the identifier runs at the start of each
/// move (`identify`, [`LqgDesign::id_a`]; not on a design without it) and the observer takes
/// the stiffness it found, and with `BEND` the feedback's reference the compliance (the
/// reference beam bent as much more as the beam is softer); without `IDENTIFY`, neither is
/// compiled in.
///
/// Written out for [`DESIGN_MODES`] = 2 (the layout `[theta, q0, q1, theta', q0', q1']`): a
/// design with another number of modes does not compile here.
#[cfg(feature = "observer")]
#[inline(always)]
pub(super) fn observe<const IDENTIFY: bool, const BEND: bool>(
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
    let rq = [rb[0], rb[1]];
    // The beam the feedback holds the hub and the modes to: the reference beam bent as much
    // more as the beam identified is softer than the model (its compliance; 1 until found).
    // The reference is smooth, so the beam follows it nearly statically and bends in
    // proportion to its compliance; rerunning the reference beam on the beam identified
    // would ring, as it was shaped on the model's.
    let soft = if BEND { softer::<IDENTIFY>(state) } else { 1.0 };
    let (tq, tdq) = ([soft * rb[0], soft * rb[1]], [soft * rb[2], soft * rb[3]]);
    let pos = dot2(r.pos, &d.ref_hub, &tq);
    let vel = dot2(r.vel, &d.ref_hub, &tdq);
    // The hub rate squared: the centrifugal term (minus the foreshortening) of the
    // reference beam, `Mf^-1 S w^2 q` in the modes' equations.
    let w2 = vel * vel;
    // `r.acc` is the acceleration the torque is held at over this tick while a move runs
    // (`crate::spline::held_acceleration`): the feedforward and the reference beam take it,
    // as the held torque swings the beam.
    let acc = r.acc;
    let at_rest = r.vel == 0.0 && acc == 0.0;
    let ff = d.mtt * acc + d.viscous * vel;
    // Made here, not where it is returned: left to itself, LLVM loads these coefficients
    // now, spills them to the stack over the reference beam's step and adds them up after
    // it (about 30 instructions of the drive's tick). `black_box` pins the sum to this
    // point for 3 (a store and a load); the value is unchanged.
    let ff = core::hint::black_box(ff);
    // Once the reference is at rest the reference beam is too: whatever it would still
    // ring with (a shaper's residual, a mode it was not tuned for) is the feedback's to
    // damp, not to follow. (A move through waypoints that stops at one for a tick resets
    // it there too; the law cannot tell that pause from the end.)
    // Each row is stored as it is made (an array made first is stored and copied).
    let omitted = if at_rest {
        state.reference = [0.0; 2 * DESIGN_MODES];
        state.move_weight *= MOVE_FADE_PER_TICK;
        0.0
    } else {
        state.move_weight = 1.0;
        unrolled!(i in [0 1 2 3] => {
            let z = dot4(d.ref_bd[i] * acc, &d.ref_ad[i], &rb);
            state.reference[i] = if i < DESIGN_MODES {
                z
            } else {
                z + w2 * dot2(-0.0, &d.ref_s[i - DESIGN_MODES], &rq)
            };
        });
        // The strain the modes the design leaves out bend the root by, statically, as the
        // reference state moves (`LqgDesign::strain_omitted` and the fields beside it): at
        // the reference's acceleration, the change of the reference beam's rates over this
        // tick (the hub's swing on it, and a payload's coupling), and the centrifugal load
        // of the beam bent as the feedback holds it. The gauge reads it on top of the
        // design's modes; the observer and the identifier expect it. (The rates' change is
        // the reference beam's, not scaled by the compliance found as the bending is: two
        // products of the identifier's ticks, the law's most costly, for a tenth of a
        // few ue.)
        let nr = state.reference;
        let omitted = dot2(
            d.strain_omitted * acc,
            &d.strain_omitted_rate,
            &[nr[2] - rb[2], nr[3] - rb[3]],
        ) + w2 * dot2(-0.0, &d.strain_omitted_spin, &tq);
        adapt::<IDENTIFY, BEND>(d, x, state, omitted);
        omitted
    };
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
    let innov_strain = x.strain - omitted - d.strain_coef[0] * head[1] - d.strain_coef[1] * head[2];
    // What each sensor says against what the observer expected it to say (the drive's
    // sensor monitor reads these, `Controller::step_in`).
    const K: f32 = 1.0 / RESIDUAL_TICKS;
    state.residual_theta += K * (libm::fabsf(innov_theta) - state.residual_theta);
    state.residual_strain += K * (libm::fabsf(innov_strain) - state.residual_strain);
    let w2_est = xo[RATE] * xo[RATE];
    let q_est = [xo[1], xo[2]];
    // The update, and the state the feedback holds it to: the hub on its reference, the
    // beam as the reference beam is.
    let reference = [pos, tq[0], tq[1], vel, tdq[0], tdq[1]];
    let w = state.move_weight;
    // The moving regulator's share: the design's, or with the identifier the one this
    // move's beam has been found to need (`Adaptation::k_move`).
    #[cfg(feature = "identify")]
    macro_rules! moving {
        ($i:tt) => {
            state.adaptation.k_move[$i]
        };
        () => {
            state.adaptation.k_move_filter
        };
    }
    #[cfg(not(feature = "identify"))]
    macro_rules! moving {
        ($i:tt) => {
            d.k_move[$i]
        };
        () => {
            d.k_move_filter
        };
    }
    // The filtered feedback the plant is driven by this tick starts from last tick's: the
    // regulator is designed with it as a state.
    let mut sigma = (d.k_filter + w * moving!()) * state.feedback_nm;
    macro_rules! update {
        ($i:ident, $pred:expr) => {{
            let xi = $pred + d.l[$i][0] * innov_theta + d.l[$i][1] * innov_strain;
            sigma += (d.k[$i] + w * moving!($i)) * (xi - reference[$i]);
            state.estimate[$i] = xi;
        }};
    }
    unrolled!(i in [0 1 2] => { update!(i, head[i]) });
    // The rates' rows, with the centrifugal term at the estimated hub rate and the modes'
    // restoring force scaled by the stiffness identified (`ad`'s entries there are `-ts
    // M^-1 Kqq` to first order in the tick).
    let stiff = stiffer::<IDENTIFY>(state);
    let xk = [stiff * xo[1], stiff * xo[2], xo[3], xo[4], xo[5]];
    unrolled!(i in [3 4 5] => {
        update!(
            i,
            dot5(d.bd[i] * u_last, &d.ad[i], &xk) + w2_est * dot2(-0.0, centrifugal(d, i), &q_est)
        )
    });
    state.strain_estimate =
        d.strain_coef[0] * state.estimate[1] + d.strain_coef[1] * state.estimate[2];
    (ff, sigma, pos)
}

/// The observer's centrifugal row for rate `i` (the hub's, `RATE`, or a mode's): the hub's
/// is the design's `obs_s_hub`, a mode's the reference beam's `ref_s` row, the same numbers.
#[cfg(feature = "observer")]
#[inline(always)]
fn centrifugal(d: &LqgDesign, i: usize) -> &[f32; DESIGN_MODES] {
    match i.checked_sub(RATE + 1) {
        None => &d.obs_s_hub,
        // (`get`: no bounds-check panic in the tick; `i` is at most `RATE + DESIGN_MODES`,
        // so the fallback is never taken, and the constant `i` folds it away.)
        Some(m) => d.ref_s.get(m).unwrap_or(&d.obs_s_hub),
    }
}

/// Without the `identify` feature the observer laws take the model as it is.
#[cfg(all(feature = "observer", not(feature = "identify")))]
#[inline(always)]
fn softer<const IDENTIFY: bool>(_: &ObserverState) -> f32 {
    1.0
}

/// See [`softer`].
#[cfg(all(feature = "observer", not(feature = "identify")))]
#[inline(always)]
fn stiffer<const IDENTIFY: bool>(_: &ObserverState) -> f32 {
    1.0
}

/// See [`softer`].
#[cfg(all(feature = "observer", not(feature = "identify")))]
#[inline(always)]
fn adapt<const IDENTIFY: bool, const BEND: bool>(
    _: &LqgDesign,
    _: &Estimate,
    _: &mut ObserverState,
    _: f32,
) {
}

/// The corner of the first-order low-pass on the observer laws' feedback, Hz (the
/// feedforward is added after it). The regulators are designed with the filter's state in
/// their model ([`k_filter`](beam_model::lqg::LqgDesign::k_filter)), so its lag at the
/// modes they control is theirs to make up, and it rolls their loop off above those modes.
///
/// The loop closes mostly through the root gauge, which sees every mode of the beam, and
/// the observer's current estimate passes the gauge's reading straight into the torque,
/// with a gain that grows with frequency (0.1 N m per ue at 1 Hz, 0.3 at 190 Hz and 0.5 at
/// 300 Hz for smc-modal with the 202 Hz filter this replaced, left out of the design). On a
/// beam simulated with a fourth mode (clamped, about 190 Hz, which the observer's two modes
/// take for theirs) that loop rang at 300 Hz, the torque swinging from limit to limit
/// (docs/design.md, 4b). Designed in, a corner of 27 Hz holds every one of 200 beams of the
/// spread quiet on four modes, at 46 Hz some still ring, and on three modes the settle
/// times are as with the 202 Hz filter (smc-modal) or shorter (lqg); at 17 Hz the 15 deg
/// p95 grew. It also takes the gauge's and the encoder's noise out of the torque (1.7 N m
/// the largest peak over the 15 deg sweep, against 3.2). The price is the hold: the
/// filter's state fed back (`u = -K x - kf f`) leaves the hub a static stiffness of `K /
/// (1 + kf)`, and lqg gives way 0.54 deg under 0.5 N m (0.24 before); smc-modal's regulator
/// at rest is designed stiffer for it (`SMC_MODAL_REST_KP_FACTOR`): 0.42 deg (0.35 before).
pub const FEEDBACK_LOWPASS_HZ: f32 = 27.04;

/// The low-pass's step at the drive's 1 kHz tick, `1 - exp(-2 pi f ts)` for
/// [`FEEDBACK_LOWPASS_HZ`] (a test checks it): 5/32, a value the FPU loads as an immediate
/// (a literal would cost 4 bytes of flash), and the step the regulators are designed with.
pub const FEEDBACK_LOWPASS_ALPHA: f32 = 0.156_25;

/// What a tick at rest on which the torque swings to a limit from the other side of zero
/// adds to the gauge's residual (`ObserverState::residual_strain`), strain: half the
/// monitor's bound (`controller::monitor::GAUGE_RESIDUAL`, 70 ue), so that one such tick
/// does not trip it and three on end do (the residual falls by a tenth a tick).
///
/// The observer laws close their loop mostly through the root gauge, and the gauge sees
/// every mode of the beam: one the observer does not model, above its two, can make the loop
/// ring. On a beam simulated with four modes (its fourth, clamped, about 190 Hz) both laws
/// rang at about 300 Hz from the first ticks of a move, the torque swinging from limit to
/// limit, until the feedback's low-pass was designed in ([`FEEDBACK_LOWPASS_HZ`]); a loop
/// that rings all the same rings while the reference moves, where the gauge monitor trips
/// on it as the gauge. This is the backstop at rest: a ring there latches
/// [`FaultFlags::RINGING`](crate::FaultFlags::RINGING) within a few ticks and the drive holds
/// on its own law, which reads the encoder alone. Through the 27 Hz filter the torque
/// reaches a limit from the other side of zero in one tick only on a command past 118 N m.
/// Not while the reference moves: the drive's law, following a move planned for an observer
/// law, bent heavy beams past 2700 ue and out of their model. None of the 22 400 runs of the
/// README's sweeps on three modes (seven seeds, with and without payloads, both laws,
/// 2026-11-27, before the filter) tripped it.
pub const RING_STEP: f32 = 35e-6;

/// The torque: the feedforward `ff` less the `feedback` low-passed ([`FEEDBACK_LOWPASS_HZ`])
/// from the feedback in last tick's. Records it within the drive's `limit` as the torque
/// the observer is told was applied next tick, and the filter's state as the feedback in
/// that (so that a saturated command does not wind the filter up), and returns it. A tick
/// at rest on which the torque swings to a limit from the other side of zero (the loop
/// ringing) adds [`RING_STEP`] to the gauge's residual and marks the move
/// ([`ObserverState::rang`]); both are looked at only at the limit, off the tick's usual
/// path.
#[cfg(feature = "observer")]
#[inline(always)]
pub(super) fn applied(law: &mut LawState, ff: f32, feedback: f32, limit: f32) -> f32 {
    // The filter's state is the feedback's share of the torque, with its sign in it
    // (`torque - ff`).
    let last = law.lqg.feedback_nm;
    let u = ff + (last - FEEDBACK_LOWPASS_ALPHA * (feedback + last));
    let applied = if u > limit {
        swung(&mut law.lqg, 1.0);
        limit
    } else if u < -limit {
        swung(&mut law.lqg, -1.0);
        -limit
    } else {
        u
    };
    law.lqg.applied_nm = applied;
    law.lqg.feedback_nm = applied - ff;
    u
}

/// At the limit on the side of `sign`, before the torque applied is recorded: a swing there
/// from the other side of zero at rest is a ring ([`RING_STEP`]). Out of line and cold, so
/// that the tick's usual path (within the limit) is as it was without it; it reads the last
/// torque from the state rather than keep it in a register over the low-pass.
#[cfg(feature = "observer")]
#[cold]
#[inline(never)]
fn swung(state: &mut ObserverState, sign: f32) {
    if state.applied_nm * sign < 0.0 && state.move_weight < 1.0 {
        state.residual_strain += RING_STEP;
        state.rang = true;
    }
}
