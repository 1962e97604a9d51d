//! The control laws: the paper's sliding-mode controller, the strain-augmented variant, the
//! PD baseline, feedforward plus PD, and the integral sliding mode (docs/design.md, section 4).
//!
//! [`Law`] is what a user chooses (gains and variant); [`ControlLaw::try_build`] validates it
//! against a [`ModalModel`] once and folds the model into a few `f32` constants, so the
//! per-tick [`ControlLaw::torque_nm`] is a handful of multiply-adds and one `tanhf`.

use crate::beam::{ParamError, ParamErrorKind};
#[cfg(doc)]
use crate::modal::ModalModel;
use crate::modal::MAX_MODES;
use crate::plant::PlantPoint;
use crate::spline::RefPoint;
use beam_kinds::GainRule;
#[cfg(feature = "observer")]
use beam_model::lqg::MAX_STATES;
use beam_model::lqg::{LqgDesign, LqgError};

pub use beam_kinds::{GainSpec, LawKind, Search, Sign, Switching};

/// PD gains: `tau = Kp (theta_r - theta) + Kd (theta_r' - theta')`.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct PdGains {
    /// Proportional gain, N m/rad.
    pub kp: f32,
    /// Derivative gain, N m s/rad.
    pub kd: f32,
}

impl PdGains {
    /// The paper's calibration controller and our baseline: Kp 20, Kd 1.
    pub const BASELINE: PdGains = PdGains { kp: 20.0, kd: 1.0 };
}

/// Sliding-mode gains: `s = W e + e'`, `tau = J (theta_r'' - W e' - A f(beta s))`.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SmcGains {
    /// Surface slope W, 1/s: s = W e + e'.
    pub w: f32,
    /// Switching gain A, rad/s^2.
    pub a: f32,
    /// Boundary-layer slope beta, s/rad.
    pub beta: f32,
    /// Switching function.
    pub switching: Switching,
}

/// The strain-augmented SMC's gains: the sliding-mode gains on y = theta + c eps_root.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct StrainSmcGains {
    /// The sliding-mode gains, applied to the blended output.
    pub smc: SmcGains,
    /// Strain blend c, rad per unit strain: y = theta + c eps_root.
    pub c: f32,
    /// Keep the model terms C M^-1 (N + K) with q estimated from the root strain.
    pub model_terms: bool,
}

/// Feedforward-plus-PD gains: `tau = Mtt theta_r'' + Kp (theta_r - theta) + Kd (theta_r' -
/// theta')`, with Mtt the whole rigid inertia (hub, beam and payload) about the axis.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct PdFfGains {
    /// Proportional gain, N m/rad.
    pub kp: f32,
    /// Derivative gain, N m s/rad.
    pub kd: f32,
}

/// Integral sliding-mode gains. On the output `y = theta + c eps_root` (c = 0: the hub angle),
/// with `e = y - theta_r` and `z` its integral over the move, the surface is
/// `s = e' + W e + Wi z` and `tau = Mtt theta_r'' - Jc (W e' + Wi e + A f(beta s))`, where
/// `Jc = [C M^-1 B]^-1` is Jeff for c = 0 and `Jeff / (1 - c gamma)` with the blend (as for
/// smc-strain). On `s = 0` the error obeys `e'' + W e' + Wi e = 0`; a constant load `d` with
/// `|d| < Jc A` is absorbed by `z`, so the output returns to the reference under it, and the
/// strain blend lets the sliding motion damp the beam.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SmcIGains {
    /// Surface slope W, 1/s.
    pub w: f32,
    /// Integral slope Wi, 1/s^2.
    pub wi: f32,
    /// Strain blend c, rad per unit strain (0: the surface is on the hub angle alone).
    pub c: f32,
    /// Switching gain A, rad/s^2: `Jc A` is the largest load the drive holds.
    pub a: f32,
    /// Boundary-layer slope beta, s/rad.
    pub beta: f32,
    /// Switching function.
    pub switching: Switching,
}

/// LQG weights (`beam_model::lqg::LqgWeights` in `f32`): the state feedback with integral
/// action and the Kalman observer are designed from them and the plant when the law is built
/// on a modal model ([`ControlLaw::try_build`]).
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct LqgGains {
    /// Hub angle weight as a stiffness, N m/rad.
    pub kp: f32,
    /// Hub rate weight, N m s/rad.
    pub kd: f32,
    /// Integral weight, N m/(rad s).
    pub ki: f32,
    /// Weight on the beam's vibration energy, (N m)^2/J.
    pub kq: f32,
    /// Disturbance torque the observer assumes, N m.
    pub sigma: f32,
}

/// Which law runs, with its gains. Each variant carries only the gains its law uses; its
/// [`LawKind`] is [`Law::kind`].
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Law {
    /// The PD baseline.
    Pd(PdGains),
    /// The paper's SMC: output theta, model terms zero, `[C M^-1 B]^-1 = Jeff`.
    Smc(SmcGains),
    /// The strain-augmented SMC on y = theta + c eps_root.
    SmcStrain(StrainSmcGains),
    /// Rigid-body feedforward plus PD.
    PdFf(PdFfGains),
    /// The integral sliding mode with rigid-body feedforward.
    SmcI(SmcIGains),
    /// LQR with integral action on a Kalman modal observer, with rigid-body feedforward.
    Lqg(LqgGains),
}

impl Law {
    /// Which law this is.
    pub const fn kind(&self) -> LawKind {
        match self {
            Law::Pd(_) => LawKind::Pd,
            Law::Smc(_) => LawKind::Smc,
            Law::SmcStrain(_) => LawKind::SmcStrain,
            Law::PdFf(_) => LawKind::PdFf,
            Law::SmcI(_) => LawKind::SmcI,
            Law::Lqg(_) => LawKind::Lqg,
        }
    }

    /// The law's name on the command line and in tables: its kind's name.
    pub const fn name(&self) -> &'static str {
        self.kind().name()
    }

    /// The gains' values in the order of their specs, [`LawKind::gains`] (the first
    /// `gains().len()` entries; the rest zero).
    pub const fn values(&self) -> [f32; MAX_GAINS] {
        match *self {
            Law::Pd(PdGains { kp, kd }) | Law::PdFf(PdFfGains { kp, kd }) => {
                [kp, kd, 0.0, 0.0, 0.0]
            }
            Law::Smc(SmcGains { w, a, beta, .. }) => [w, a, beta, 0.0, 0.0],
            Law::SmcStrain(StrainSmcGains {
                smc: SmcGains { w, a, beta, .. },
                c,
                ..
            }) => [w, a, beta, c, 0.0],
            Law::SmcI(SmcIGains {
                w, wi, a, beta, c, ..
            }) => [w, wi, a, beta, c],
            Law::Lqg(LqgGains {
                kp,
                kd,
                ki,
                kq,
                sigma,
            }) => [kp, kd, ki, kq, sigma],
        }
    }

    /// How many of the beam's first clamped periods a planned move lasts at least, when the
    /// planner picks its time ([`crate::Limits::for_law`]); 0 for no floor. The LQG law
    /// bends a reference beam through the move and feeds forward the torque that does it: a
    /// base move much shorter than the first period asks for more than the limit (15 deg in
    /// 0.083 s, 0.45 periods of the aluminium beam: 6-10 N m, settled in 0.98 s; in 0.12 s,
    /// 0.66 periods: 1.9 N m, 0.61 s). The other laws leave the beam to the shaper and are
    /// fastest at the torque-limited time.
    pub const fn min_move_periods(&self) -> f32 {
        match self {
            Law::Lqg(_) => 0.66,
            Law::Pd(_) | Law::Smc(_) | Law::SmcStrain(_) | Law::PdFf(_) | Law::SmcI(_) => 0.0,
        }
    }

    /// Checks every gain against its spec's sign rule ([`LawKind::gains`], the rule the gain
    /// table's build applies too).
    pub fn check(&self) -> Result<(), ParamError> {
        let (kind, values) = (self.kind(), self.values());
        let rules = kind.gain_names().iter().zip(kind.gain_signs());
        for ((&field, sign), &v) in rules.zip(&values) {
            sign.check(v as f64).map_err(|rule| ParamError {
                field,
                kind: match rule {
                    GainRule::NonFinite => ParamErrorKind::NonFinite,
                    GainRule::NotPositive => ParamErrorKind::NotPositive,
                    GainRule::Negative => ParamErrorKind::Negative,
                },
            })?;
        }
        Ok(())
    }
}

/// Most gains a law has.
pub const MAX_GAINS: usize = 5;

/// The measured state the laws use, SI.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Estimate {
    /// Hub angle, rad.
    pub theta: f32,
    /// Hub velocity, rad/s (filtered).
    pub omega: f32,
    /// Root strain (dimensionless).
    pub strain: f32,
    /// Root strain rate, 1/s (filtered).
    pub strain_rate: f32,
}

/// What a law carries from one tick to the next: the integral of the hub error (smc-i, lqg)
/// and the observer's state (lqg). Zero when a move starts.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct LawState {
    /// Integral of `theta - theta_r` since the move started, rad s.
    pub integral: f32,
    /// The LQG law's observer and reference beam.
    #[cfg(feature = "observer")]
    pub lqg: ObserverState,
}

/// The LQG law's state between ticks.
#[cfg(feature = "observer")]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ObserverState {
    /// The observer's state estimate, in [`LqgDesign`]'s layout.
    pub estimate: [f32; MAX_STATES],
    /// The reference beam's modes and rates, see [`LqgDesign::ref_ad`].
    pub reference: [f32; 2 * MAX_MODES],
    /// The torque the drive applied last tick, within the limit, N m.
    pub applied_nm: f32,
    /// The observer has been started from the measured hub angle.
    pub observing: bool,
}

/// Flexible modes the LQG law observes and controls: the first (see `LawPlant::lqg`).
pub const LQG_MODES: usize = 2;

/// The noise the LQG observer assumes on the root strain gauge, strain: a bridge amplifier's
/// typical floor (0.5 ue), well above a 24-bit converter's quantisation.
pub const ASSUMED_STRAIN_NOISE: f64 = 1e-6;

/// What a law is built on: the plant at the drive's payload ([`PlantPoint`], what a drive
/// carries compiled in), or a whole modal model, on which the LQG law is designed too.
pub trait LawPlant {
    /// The plant's numbers the laws read.
    fn point(&self) -> PlantPoint;
    /// The LQG design for `gains` on this plant, sampled at `ts_s`; `None` if this plant
    /// cannot design one (a [`PlantPoint`]). A [`ModalModel`] designs it with the compiled
    /// `[drive]`'s instruments as the sensor noise (in `crate::gains`, which knows them).
    fn lqg(&self, _gains: &LqgGains, _ts_s: f64) -> Option<Result<LqgDesign, LqgError>> {
        None
    }
}

impl LawPlant for PlantPoint {
    fn point(&self) -> PlantPoint {
        *self
    }
}

/// gamma = e' Mqq^-1 h, how much a hub acceleration shows in the root strain of the held
/// beam: the blended output y = theta + c eps_root has the input gain (1 - c gamma) / Jeff.
pub fn strain_coupling(plant: impl Into<PlantPoint>) -> f64 {
    plant.into().strain_coupling()
}

/// `1 - c gamma`, refused below [`PlantPoint::MIN_BLEND_RATIO`], where the blend would take
/// the output's control direction away.
fn input_gain_ratio(c: f64, m: &PlantPoint) -> Result<f64, ParamError> {
    m.blend_ratio(c).ok_or(ParamError {
        field: "c",
        kind: ParamErrorKind::OutOfRange,
    })
}

/// A validated law folded with the model constants it needs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ControlLaw {
    law: Law,
    /// Jeff for the paper law; [C M^-1 B]^-1 for the strain law, kg m^2.
    inertia: f32,
    /// Mtt, the whole rigid inertia, for the laws with rigid-body feedforward, kg m^2.
    rigid_inertia: f32,
    /// The integral's bound (smc-i): `Jeff A beta Wi |z|` stays within the torque limit the
    /// controller's settings give, so the integral cannot wind up past what it can use.
    integral_max: f32,
    /// Model-term coefficients (strain law with `model_terms`), see `try_build`.
    model: ModelTerms,
    /// The LQG design (lqg; all zero for the other laws).
    #[cfg(feature = "observer")]
    observer: LqgDesign,
}

/// An all-zero design, for the laws without an observer.
#[cfg(feature = "observer")]
const NO_OBSERVER: LqgDesign = LqgDesign {
    ad: [[0.0; MAX_STATES]; MAX_STATES],
    bd: [0.0; MAX_STATES],
    strain_coef: [0.0; MAX_MODES],
    l: [[0.0; 2]; MAX_STATES],
    k: [0.0; MAX_STATES],
    ki: 0.0,
    ref_ad: [[0.0; 2 * MAX_MODES]; 2 * MAX_MODES],
    ref_bd: [0.0; 2 * MAX_MODES],
    ff_q: [0.0; MAX_MODES],
    ff_dq: [0.0; MAX_MODES],
    ref_s: [[0.0; MAX_MODES]; MAX_MODES],
    obs_s: [[0.0; MAX_MODES]; 1 + MAX_MODES],
    ff_s: [0.0; MAX_MODES],
    jeff: 0.0,
    viscous: 0.0,
    torque_limit_nm: 0.0,
};

/// `C M^-1 (N + K)` with q = [q1, 0, ..] from the root strain, reduced to scalars.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct ModelTerms {
    enabled: bool,
    /// 1 / (t/2 phi_1''(x_g)): modal coordinate per unit strain.
    q_per_strain: f32,
    r_theta: f32,
    viscous: f32,
    s11: f32,
    k_sum: f32,
    c_sum: f32,
    s_sum: f32,
}

impl ControlLaw {
    /// Validates `law`'s gains and precomputes what the tick needs from the plant: a
    /// [`PlantPoint`] (the drive's compiled plant at its payload) or a [`ModalModel`]. The
    /// LQG law is designed on a modal model only (sampled at [`crate::DEFAULT_TS_S`], with
    /// the compiled `[drive]`'s instruments as its sensor noise); on a [`PlantPoint`] it is
    /// refused.
    pub fn try_build(law: Law, plant: impl LawPlant) -> Result<Self, ParamError> {
        let model = &plant.point();
        let jeff = model.jeff;
        let plain = Self {
            law,
            inertia: jeff as f32,
            rigid_inertia: model.mtt as f32,
            integral_max: 0.0,
            model: ModelTerms::default(),
            #[cfg(feature = "observer")]
            observer: NO_OBSERVER,
        };
        // Every gain's sign, by the law's spec; then what each law needs of the plant.
        law.check()?;
        match law {
            Law::Pd(_) | Law::PdFf(_) | Law::Smc(_) => Ok(plain),
            Law::SmcStrain(sg) => Self::strain_law(law, sg, model),
            Law::SmcI(g) => {
                // The blended output's input gain, as for smc-strain (Jeff when c = 0).
                let jc = Self::blended_inertia(g.c as f64, model)?;
                // Jc A beta Wi |z| <= the drive's limit (infinite without integral action).
                let per_z = jc * (g.a * g.beta * g.wi) as f64;
                let limit = model.torque_limit_nm;
                Ok(Self {
                    inertia: jc as f32,
                    integral_max: if per_z > 0.0 {
                        (limit / per_z) as f32
                    } else {
                        0.0
                    },
                    ..plain
                })
            }
            #[cfg(feature = "observer")]
            Law::Lqg(g) => Self::lqg_law(plain, &g, &plant),
            #[cfg(not(feature = "observer"))]
            Law::Lqg(_) => Err(ParamError {
                field: "lqg",
                kind: ParamErrorKind::NeedsModel,
            }),
        }
    }

    /// The LQG law's design on `plant` (see [`ControlLaw::try_build`]).
    #[cfg(feature = "observer")]
    fn lqg_law(plain: Self, g: &LqgGains, plant: &impl LawPlant) -> Result<Self, ParamError> {
        let design = plant
            .lqg(g, crate::DEFAULT_TS_S as f64)
            .ok_or(ParamError {
                field: "lqg",
                kind: ParamErrorKind::NeedsModel,
            })?
            .map_err(|e| ParamError {
                field: "lqg",
                kind: match e {
                    LqgError::Weights => ParamErrorKind::OutOfRange,
                    LqgError::Numerics => ParamErrorKind::NoDesign,
                },
            })?;
        // |Ki z| within the limit: the integral cannot wind up past what it can use.
        let ki = libm::fabsf(design.ki);
        Ok(Self {
            integral_max: if ki > 0.0 {
                design.torque_limit_nm / ki
            } else {
                0.0
            },
            #[cfg(feature = "observer")]
            observer: design,
            ..plain
        })
    }

    /// `[C M0^-1 B]^-1 = Jeff / (1 - c gamma)` for the output y = theta + c eps_root (see
    /// `strain_law`); Jeff itself for c = 0.
    fn blended_inertia(c: f64, m: &PlantPoint) -> Result<f64, ParamError> {
        Ok(m.jeff / input_gain_ratio(c, m)?)
    }

    /// The strain law's constants. With x = [theta; q], M0 = M(q = 0) and the output row
    /// C = [1, c e'] (e the root strain coefficients), block inversion gives
    /// C M0^-1 B = (1 - c gamma) / Jeff with gamma = e' Mqq^-1 h, and the row
    /// C M0^-1 = [r_theta, r_q] with r_theta = (1 - c gamma)/Jeff and
    /// r_q = c e' Mqq^-1 - r_theta h' Mqq^-1.
    fn strain_law(law: Law, g: StrainSmcGains, m: &PlantPoint) -> Result<Self, ParamError> {
        let c = g.c as f64;
        let e = m.root_strain_coef;
        let ratio = input_gain_ratio(c, m)?;
        let r_theta = ratio / m.jeff;
        // Past the model's modes every vector is zero, and so is each added term.
        let r_q: [f64; MAX_MODES] =
            core::array::from_fn(|j| c * m.minv_e[j] - r_theta * m.minv_h[j]);
        let col0 = |a: &[f64; MAX_MODES]| (0..MAX_MODES).map(|j| r_q[j] * a[j]).sum::<f64>();
        let model = if g.model_terms && e[0].abs() > 0.0 {
            ModelTerms {
                enabled: true,
                q_per_strain: (1.0 / e[0]) as f32,
                r_theta: r_theta as f32,
                viscous: m.viscous_nms as f32,
                s11: m.s_col0[0] as f32,
                k_sum: col0(&m.kqq_col0) as f32,
                c_sum: col0(&m.cq_col0) as f32,
                s_sum: col0(&m.s_col0) as f32,
            }
        } else {
            ModelTerms::default()
        };
        Ok(Self {
            law,
            inertia: (1.0 / r_theta) as f32,
            rigid_inertia: m.mtt as f32,
            integral_max: 0.0,
            model,
            #[cfg(feature = "observer")]
            observer: NO_OBSERVER,
        })
    }

    /// The law as chosen.
    pub fn law(&self) -> &Law {
        &self.law
    }

    /// The unsaturated torque command for the estimate `x` and reference `r`, N m, advancing
    /// the law's own state (the integral of smc-i) by one tick of `ts_s`. May be non-finite
    /// only if `x` or `r` is; the caller guards and saturates. Always inlined: with two
    /// controllers in one binary (the PIL drive's sequence and commanded paths) a plain
    /// hint let it be outlined, which cost about 30 instructions a tick.
    #[inline(always)]
    pub fn torque_nm(&self, x: &Estimate, r: &RefPoint, state: &mut LawState, ts_s: f32) -> f32 {
        match self.law {
            Law::Pd(g) => g.kp * (r.pos - x.theta) + g.kd * (r.vel - x.omega),
            Law::Smc(g) => {
                let (e, de) = (x.theta - r.pos, x.omega - r.vel);
                let s = g.w * e + de;
                self.inertia * (r.acc - g.w * de - g.a * g.switching.apply(g.beta * s))
            }
            Law::SmcStrain(StrainSmcGains { smc: g, c, .. }) => {
                let y = x.theta + c * x.strain;
                let dy = x.omega + c * x.strain_rate;
                let (e, de) = (y - r.pos, dy - r.vel);
                let s = g.w * e + de;
                let mut v = r.acc - g.w * de - g.a * g.switching.apply(g.beta * s);
                let m = &self.model;
                if m.enabled {
                    let (q, dq) = (x.strain * m.q_per_strain, x.strain_rate * m.q_per_strain);
                    let w = x.omega;
                    v += m.r_theta * (2.0 * w * m.s11 * q * dq + m.viscous * w)
                        + (m.k_sum - w * w * m.s_sum) * q
                        + m.c_sum * dq;
                }
                self.inertia * v
            }
            Law::PdFf(g) => {
                self.rigid_inertia * r.acc + g.kp * (r.pos - x.theta) + g.kd * (r.vel - x.omega)
            }
            Law::SmcI(g) => {
                let y = x.theta + g.c * x.strain;
                let dy = x.omega + g.c * x.strain_rate;
                let (e, de) = (y - r.pos, dy - r.vel);
                let m = self.integral_max;
                let z = state.integral + e * ts_s;
                // Comparisons, not clamp/min/max (an assertion or a library call on the M4F).
                state.integral = if z > m {
                    m
                } else if z < -m {
                    -m
                } else {
                    z
                };
                let s = de + g.w * e + g.wi * state.integral;
                self.rigid_inertia * r.acc
                    - self.inertia * (g.w * de + g.wi * e + g.a * g.switching.apply(g.beta * s))
            }
            #[cfg(feature = "observer")]
            Law::Lqg(_) => self.lqg_torque(x, r, state, ts_s),
            // Never built without the feature (`try_build` refuses it).
            #[cfg(not(feature = "observer"))]
            Law::Lqg(_) => 0.0,
        }
    }

    /// The LQG tick: the observer's predict (with the torque applied last tick) and update
    /// (with the hub angle and root strain), then the state feedback about the reference
    /// state (the hub on its reference, the beam bent as the reference's acceleration bends
    /// it), the integral, and the rigid-body feedforward. Fixed loops over the whole layout:
    /// no bound is read at run time.
    #[cfg(feature = "observer")]
    #[inline(always)]
    fn lqg_torque(&self, x: &Estimate, r: &RefPoint, law: &mut LawState, ts_s: f32) -> f32 {
        const RATE: usize = 1 + MAX_MODES;
        let d = &self.observer;
        let state = &mut law.lqg;
        if !state.observing {
            // From rest at the measured angle: a move starts with the hub still.
            state.estimate = [0.0; MAX_STATES];
            state.estimate[0] = x.theta;
            state.reference = [0.0; 2 * MAX_MODES];
            state.applied_nm = 0.0;
            state.observing = true;
        }
        let xo = &state.estimate;
        let mut pred = [0.0f32; MAX_STATES];
        for (p, (row, b)) in pred.iter_mut().zip(d.ad.iter().zip(&d.bd)) {
            let mut acc = b * state.applied_nm;
            for (a, xj) in row.iter().zip(xo) {
                acc += a * xj;
            }
            *p = acc;
        }
        // The centrifugal term at the estimated hub rate, on the rates' rows.
        let w2_est = xo[RATE] * xo[RATE];
        for (p, row) in pred[RATE..].iter_mut().zip(&d.obs_s) {
            let mut acc = 0.0;
            for (a, q) in row.iter().zip(&xo[1..RATE]) {
                acc += a * q;
            }
            *p += w2_est * acc;
        }
        let innov_theta = x.theta - pred[0];
        let mut innov_strain = x.strain;
        for (e, q) in d.strain_coef.iter().zip(&pred[1..]) {
            innov_strain -= e * q;
        }
        // The reference beam at this tick, its feedforward, and its next state.
        let rb = &state.reference;
        let mut u = d.jeff * r.acc + d.viscous * r.vel;
        // The hub rate squared: the centrifugal term (minus the foreshortening) of the
        // reference beam, `M^-1 [-h' ; I] w^2 S q` in the hub's and the modes' equations.
        let w2 = r.vel * r.vel;
        for (((fq, fdq), fs), (q, dq)) in d
            .ff_q
            .iter()
            .zip(&d.ff_dq)
            .zip(&d.ff_s)
            .zip(rb.iter().zip(&rb[MAX_MODES..]))
        {
            u += fq * q + fdq * dq + w2 * fs * q;
        }
        let mut next = [0.0f32; 2 * MAX_MODES];
        for (nz, (row, b)) in next.iter_mut().zip(d.ref_ad.iter().zip(&d.ref_bd)) {
            let mut acc = b * r.acc;
            for (a, z) in row.iter().zip(rb) {
                acc += a * z;
            }
            *nz = acc;
        }
        for (nz, row) in next[MAX_MODES..].iter_mut().zip(&d.ref_s) {
            let mut acc = 0.0;
            for (a, q) in row.iter().zip(rb) {
                acc += a * q;
            }
            *nz += w2 * acc;
        }
        for (i, (xi, (p, l))) in state
            .estimate
            .iter_mut()
            .zip(pred.iter().zip(&d.l))
            .enumerate()
        {
            *xi = p + l[0] * innov_theta + l[1] * innov_strain;
            let reference = if i == 0 {
                r.pos
            } else if i < RATE {
                state.reference[i - 1]
            } else if i == RATE {
                r.vel
            } else {
                state.reference[i - 1 - RATE + MAX_MODES]
            };
            u -= d.k[i] * (*xi - reference);
        }
        // Once the reference is at rest the reference beam is too: whatever it would still
        // ring with (a shaper's residual, a mode it was not tuned for) is the feedback's to
        // damp, not to follow. (A move through waypoints that stops at one for a tick resets
        // it there too; the law cannot tell that pause from the end.)
        state.reference = if r.vel == 0.0 && r.acc == 0.0 {
            [0.0; 2 * MAX_MODES]
        } else {
            next
        };
        let m = self.integral_max;
        let z = law.integral + (state.estimate[0] - r.pos) * ts_s;
        law.integral = if z > m {
            m
        } else if z < -m {
            -m
        } else {
            z
        };
        u -= d.ki * law.integral;
        let limit = d.torque_limit_nm;
        state.applied_nm = if u > limit {
            limit
        } else if u < -limit {
            -limit
        } else {
            u
        };
        u
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_laws_values_follow_its_spec_order() {
        // `values` lists each law's gains in `LawKind::gains` order: set each gain to its
        // index and read it back by the spec's name.
        let laws = [
            Law::Pd(PdGains { kp: 1.0, kd: 2.0 }),
            Law::PdFf(PdFfGains { kp: 1.0, kd: 2.0 }),
            Law::Smc(SmcGains {
                w: 1.0,
                a: 2.0,
                beta: 3.0,
                switching: Switching::Tanh,
            }),
            Law::SmcStrain(StrainSmcGains {
                smc: SmcGains {
                    w: 1.0,
                    a: 2.0,
                    beta: 3.0,
                    switching: Switching::Tanh,
                },
                c: 4.0,
                model_terms: false,
            }),
            Law::SmcI(SmcIGains {
                w: 1.0,
                wi: 2.0,
                a: 3.0,
                beta: 4.0,
                c: 5.0,
                switching: Switching::Tanh,
            }),
            Law::Lqg(LqgGains {
                kp: 1.0,
                kd: 2.0,
                ki: 3.0,
                kq: 4.0,
                sigma: 5.0,
            }),
        ];
        for law in laws {
            let names = law.kind().gain_names();
            let values = law.values();
            for (i, name) in names.iter().enumerate() {
                assert_eq!(values[i], (i + 1) as f32, "{} {name}", law.name());
            }
            assert!(values[names.len()..].iter().all(|v| *v == 0.0));
        }
        // Every kind is covered above.
        assert_eq!(laws.len(), LawKind::ALL.len());
    }
    use crate::beam::{Beam, BeamParams};
    use crate::modal::ModalModel;

    fn model() -> ModalModel<3> {
        ModalModel::try_build(&Beam::try_build(BeamParams::aluminium()).unwrap()).unwrap()
    }

    const GAINS: SmcGains = SmcGains {
        w: 20.0,
        a: 5.0,
        beta: 0.5,
        switching: Switching::Tanh,
    };

    const fn strain(c: f32) -> Law {
        Law::SmcStrain(StrainSmcGains {
            smc: GAINS,
            c,
            model_terms: false,
        })
    }

    #[test]
    fn on_the_reference_the_smc_commands_the_rigid_feedforward() {
        // With zero tracking error, s = 0 and u = Jeff theta_r'': the inverse dynamics of the
        // hub seen through the Schur complement.
        let m = model();
        let law = ControlLaw::try_build(Law::Smc(GAINS), &m).unwrap();
        let r = RefPoint {
            pos: 0.3,
            vel: 2.0,
            acc: 40.0,
        };
        let x = Estimate {
            theta: 0.3,
            omega: 2.0,
            ..Default::default()
        };
        let u = law.torque_nm(&x, &r, &mut LawState::default(), 1e-3);
        assert!((u as f64 - m.jeff * 40.0).abs() < 1e-5 * m.jeff * 40.0);
        // Behind the reference the SMC pushes forward.
        let behind = Estimate {
            theta: 0.2,
            omega: 2.0,
            ..Default::default()
        };
        assert!(law.torque_nm(&behind, &r, &mut LawState::default(), 1e-3) > u);
    }

    #[test]
    fn smc_i_feeds_the_whole_rigid_inertia_forward_and_its_blend_sees_the_strain() {
        let m = model();
        let g = SmcIGains {
            w: 30.0,
            wi: 200.0,
            c: 0.0,
            a: 100.0,
            beta: 0.5,
            switching: Switching::Tanh,
        };
        let r = RefPoint {
            pos: 0.3,
            vel: 2.0,
            acc: 40.0,
        };
        let on = Estimate {
            theta: 0.3,
            omega: 2.0,
            ..Default::default()
        };
        // On the reference the torque is Mtt theta_r'': the hub, beam and payload inertia,
        // not Jeff (about 3.8 times Jeff on the aluminium beam).
        let law = ControlLaw::try_build(Law::SmcI(g), &m).unwrap();
        let u = law.torque_nm(&on, &r, &mut LawState::default(), 1e-3);
        assert!((u as f64 - m.mtt * 40.0).abs() < 1e-5 * m.mtt * 40.0, "{u}");
        // Without a blend the strain is ignored; with one, the same strain changes the torque.
        let bent = Estimate {
            strain: 2e-4,
            strain_rate: 0.05,
            ..on
        };
        assert_eq!(law.torque_nm(&bent, &r, &mut LawState::default(), 1e-3), u);
        let blended = ControlLaw::try_build(Law::SmcI(SmcIGains { c: 5.0, ..g }), &m).unwrap();
        assert_ne!(
            blended.torque_nm(&bent, &r, &mut LawState::default(), 1e-3),
            u
        );
    }

    #[test]
    fn strain_law_with_zero_blend_and_no_model_terms_is_the_paper_law() {
        let m = model();
        let paper = ControlLaw::try_build(Law::Smc(GAINS), &m).unwrap();
        let strain = ControlLaw::try_build(strain(0.0), &m).unwrap();
        let r = RefPoint {
            pos: 0.1,
            vel: -1.0,
            acc: 3.0,
        };
        let x = Estimate {
            theta: 0.15,
            omega: -0.5,
            strain: 1e-4,
            strain_rate: 1e-2,
        };
        assert!(
            (paper.torque_nm(&x, &r, &mut LawState::default(), 1e-3)
                - strain.torque_nm(&x, &r, &mut LawState::default(), 1e-3))
            .abs()
                < 1e-5
        );
    }

    #[test]
    fn gains_are_validated_with_the_field_named() {
        let m = model();
        let err = |law| ControlLaw::try_build(law, &m).unwrap_err();
        assert_eq!(err(Law::Smc(SmcGains { w: 0.0, ..GAINS })).field, "w");
        assert_eq!(
            err(Law::Smc(SmcGains {
                beta: f32::NAN,
                ..GAINS
            }))
            .kind,
            ParamErrorKind::NonFinite
        );
        assert_eq!(err(Law::Pd(PdGains { kp: -1.0, kd: 1.0 })).field, "kp");
        // A blend so large that the surface loses its control direction is rejected.
        let gamma_sign = strain_coupling(&m).signum() as f32;
        assert_eq!(err(strain(gamma_sign * 1e6)).field, "c");
    }
}
