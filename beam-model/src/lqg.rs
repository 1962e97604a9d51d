//! A linear-quadratic-Gaussian design for the slewing beam: the sampled linear model about
//! rest, a steady-state Kalman filter (the modal state observer) and a state-feedback gain
//! with integral action, both from discrete algebraic Riccati equations.
//!
//! The state is `x = [theta, q_1..q_n, theta', q_1'..q_n']` (hub angle, modal coordinates
//! and their rates); the input the hub torque; the outputs the hub angle (encoder) and the
//! root strain `e' q` (the gauge). About rest (`theta' = 0`, `q = 0`) the model is
//! `M x'' + C x' + K x = b tau` with `M = [[Mtt, h'], [h, Mqq]]`, `C = diag(c_v, Cq)`,
//! `K = diag(0, Kqq)`, `b = e_0`: the centrifugal and Coriolis terms are second order and
//! dropped, Coulomb friction is left to the integral action.
//!
//! `f64`, fixed-size, no allocation: it runs where the model is built (a host tool, or the
//! build script that compiles a gain table), never per tick. [`LqgDesign`] holds the result
//! in `f32`, ready for a drive's tick.
//!
//! Method: zero-order-hold discretisation by the matrix exponential of Van Loan's augmented
//! matrix (scaling and squaring of a Taylor series), and both Riccati equations by the
//! structure-preserving doubling algorithm (quadratic convergence; Chu, Fan, Lin, Wang,
//! "Structure-preserving algorithms for periodic discrete-time algebraic Riccati equations",
//! 2004), which needs no eigen-decomposition.

// Dense matrix algebra reads best with its indices: `a[i][j]` as in the formulas.
#![allow(clippy::needless_range_loop)]

use crate::modal::ModalModel;

/// Flexible modes a design observes and controls. The first two: a design that also observes
/// the higher modes tracks them on the model's frequencies, and a beam a few percent off
/// those turns them unstable (spillover; with 1 % damping there is no margin to spare). Fixed,
/// so that a drive's tick runs fixed loops over no more than it uses.
pub const DESIGN_MODES: usize = 2;

/// States of a design: the hub angle and rate, and two per flexible mode.
pub const MAX_STATES: usize = 2 + 2 * DESIGN_MODES;

mod dense;
use dense::{dare, expm, inverse, mul, transpose, Mat, D, ZERO};

mod closed_loop;
pub use closed_loop::{loop_radius, LoopSetting};

/// The design's weights: a quadratic cost on the error from the reference and a Gaussian
/// model of what disturbs and corrupts the loop.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LqgWeights {
    /// Hub angle weight as a stiffness, N m/rad: for a rigid hub the loop's proportional
    /// gain tends to it.
    pub kp: f64,
    /// Hub rate weight, N m s/rad.
    pub kd: f64,
    /// Integral-of-angle weight, N m/(rad s).
    pub ki: f64,
    /// Weight on the beam's vibration energy, (N m)^2/J: how much the loop spends to damp it.
    pub kq: f64,
    /// Standard deviation of the disturbance torque the observer assumes, N m: larger trusts
    /// the sensors more (a faster observer).
    pub sigma_nm: f64,
    /// The regulator while the reference moves: one designed on the same weights so that every
    /// closed-loop pole of the nominal model (the integral's aside) lies left of `-move_rate`,
    /// 1/s (an LQR with a prescribed degree of stability), the loop's own regulator `K` at
    /// rest. 0: `K` throughout ([`LqgDesign::k_move`] is zero). With a payload lighter than
    /// [`LqgWeights::move_rate_payload_kg`], [`LqgWeights::move_rate_at`].
    pub move_rate: f64,
    /// The moving regulator's rate on the beam without a payload, 1/s: it falls along a
    /// straight line to [`LqgWeights::move_rate`] at [`LqgWeights::move_rate_payload_kg`]
    /// and stays there for heavier payloads. Not above `move_rate`: `move_rate` at every
    /// payload.
    pub move_rate_unloaded: f64,
    /// The payload from which the moving regulator's rate is [`LqgWeights::move_rate`], kg.
    pub move_rate_payload_kg: f64,
    /// With a moving regulator ([`LqgWeights::move_rate`] above 0), the hub angle weight of
    /// the regulator at rest, N m/rad, in place of [`LqgWeights::kp`] (which the moving
    /// one keeps): a stiffer hold. 0: `kp`.
    pub rest_kp: f64,
    /// Whether the observer reads the encoder at rest as the count's interval
    /// ([`LqgDesign::count_interval`]), not as a noisy point.
    pub count_interval: bool,
    /// Whether the drive identifies the beam's stiffness at the start of each move and
    /// corrects its observer's model for the rest of it ([`LqgDesign::id_a`]).
    pub identify: bool,
    /// The step per tick of the first-order low-pass the drive runs its feedback through,
    /// in (0, 1] (`f+ = f + step (u - f)`): the regulator is designed on the sampled model
    /// with the filter's state in it ([`LqgDesign::k_filter`]), so that a filter slow enough
    /// to roll the loop off above the modes it knows costs it no phase at them. 1: no filter.
    pub feedback_lowpass: f64,
}

/// What the sensors resolve, for the observer's measurement noise.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SensorNoise {
    /// Hub angle noise (the encoder's quantisation, step / sqrt(12)), rad.
    pub theta_rad: f64,
    /// The encoder's count as the drive reads it, rad, negative when the counter counts down
    /// as the hub turns positive: a reading `theta` says the hub is between `theta` and
    /// `theta + encoder_step_rad` (0: not known).
    pub encoder_step_rad: f64,
    /// Root strain noise (the converter's), strain.
    pub strain: f64,
}

/// Why a design failed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LqgError {
    /// A weight or noise level is not finite and positive (or, for `ki` and `kq`, negative).
    Weights,
    /// A matrix was singular, or a Riccati iteration did not converge.
    Numerics,
    /// The model has more modes than a design holds ([`DESIGN_MODES`]): reduce it first
    /// ([`leading_modes`]).
    Modes,
}

/// An LQG design in `f32`, for the tick: `x_pred = Ad x + Bd u_prev`, `x = x_pred + L (y -
/// C x_pred)`, `u = ff - K [x - x_ref; z]`.
///
/// The layout is fixed whatever the model's mode count, so the tick has no variable bounds:
/// index 0 the hub angle, `1 + i` mode i's coordinate, `1 + DESIGN_MODES` the hub rate,
/// `2 + DESIGN_MODES + i` mode i's rate; entries of modes past the model's are zero.
/// Every entry is an `f32`, laid out in order ([`LqgDesign::mix`] runs over them as one
/// list).
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
#[repr(C)]
pub struct LqgDesign {
    /// The sampled state matrix without its first column. No force depends on the hub angle,
    /// so that column is exactly `[1, 0, .., 0]` (checked when the design is made): row 0
    /// adds the angle itself, the other rows nothing, and a tick skips its six products.
    /// `ad[i][j - 1]` is the full matrix's entry `(i, j)`, `j >= 1`.
    pub ad: [[f32; MAX_STATES - 1]; MAX_STATES],
    /// The sampled input column, per N m.
    pub bd: [f32; MAX_STATES],
    /// Root strain per modal coordinate (the second output row is `[0, e, 0, 0]`).
    pub strain_coef: [f32; DESIGN_MODES],
    /// Root strain per unit of the reference's acceleration (rad/s^2) of the modes the
    /// design leaves out, bent statically by it ([`OmittedStrain`]): with the two fields
    /// below, what the observer and the identifier expect the gauge to read on top of the
    /// design's modes' strain while the reference moves.
    ///
    /// Those modes are stiff (97 Hz and up on the aluminium beam), so under a move they
    /// bend almost statically: 10 ue and more at the planner's shortest moves. Not expected,
    /// the observer read it as its own modes' strain and, after each fast move, held the hub
    /// a tenth of a degree off; the identifier read it as a softer beam.
    pub strain_omitted: f32,
    /// The same per change of the reference beam's mode rates over a tick (m/s): the hub
    /// swings about the rigid reference as the beam does (`ref_hub`), and a payload couples
    /// the modes' accelerations into the ones left out.
    pub strain_omitted_rate: [f32; DESIGN_MODES],
    /// The same per (rad/s)^2 of the reference's hub rate and per modal coordinate of the
    /// reference beam (m): the centrifugal load of the bent beam (at 20 rad/s, 5-10 ue).
    pub strain_omitted_spin: [f32; DESIGN_MODES],
    /// The Kalman gain, a column per output: hub angle, root strain.
    pub l: [[f32; 2]; MAX_STATES],
    /// The state-feedback gain, N m per state unit.
    pub k: [f32; MAX_STATES],
    /// What the regulator adds while the reference moves ([`LqgWeights::move_rate`]), N m per
    /// state unit: the loop's gain is `k + w k_move`, `w` 1 while the reference moves and
    /// fading after it stops (the tick's). Zero for a single regulator.
    pub k_move: [f32; MAX_STATES],
    /// The state feedback's gain on the feedback low-pass's state (the filtered feedback
    /// torque applied last tick, [`LqgWeights::feedback_lowpass`]), per N m; 0 without
    /// the filter.
    pub k_filter: f32,
    /// What the moving regulator adds to [`LqgDesign::k_filter`], as `k_move` to `k`.
    pub k_move_filter: f32,
    /// How the moving regulator's share changes with the beam's compliance against the
    /// model's, less 1, as the drive identifies it ([`LqgWeights::identify`]): the loop's
    /// gain while moving is `k + w (k_move + c k_move_compliance)`. The secant of the
    /// moving regulator designed on the model with its modes' stiffness scaled to each end
    /// of [`IDENTIFY_STIFFNESS`]. Zero without the identifier or a moving regulator.
    pub k_move_compliance: [f32; MAX_STATES],
    /// What the compliance adds to [`LqgDesign::k_move_filter`], as
    /// `k_move_compliance` to `k_move`.
    pub k_move_filter_compliance: f32,
    /// The encoder's count interval about a reading, rad, `[min(step, 0), max(step, 0)]`: at
    /// rest the observer corrects its angle only by how far its prediction lies outside
    /// `[theta + lo, theta + hi]` ([`LqgWeights::count_interval`]); `[0, 0]` reads the angle as
    /// a point.
    pub count_interval: [f32; 2],
    /// The integral's gain, N m/(rad s).
    pub ki: f32,
    /// The reference beam: the modes of the beam as the reference's torque drives it, its
    /// hub free to turn (the hub-free dynamics `Mf q'' + Cq q' + Kqq q = -h theta_r''`, with
    /// `Mf = Mqq - h h' / Mtt`), sampled: state `[q_0, q_1, q_0', q_1']`, `r+ = ref_ad r +
    /// ref_bd theta_r''`. The reference's hub angle `theta_r` is the rigid body's; the beam
    /// swinging on it turns the hub by `ref_hub . q` about it (the beam's angular momentum
    /// about the hub is the rigid body's). The torque `Mtt theta_r''` drives the whole beam
    /// along this, so a reference shaped on the hub-free modes leaves the reference beam at
    /// rest when it ends. A beam bent and swinging as the reference itself makes it is not an
    /// error for the feedback.
    pub ref_ad: [[f32; 2 * DESIGN_MODES]; 2 * DESIGN_MODES],
    /// The reference beam's input column, per rad/s^2.
    pub ref_bd: [f32; 2 * DESIGN_MODES],
    /// The hub's turn about the rigid reference per modal coordinate, `-h / Mtt`: the
    /// reference state's hub angle is `theta_r + ref_hub . q`, its rate `theta_r' + ref_hub .
    /// q'`.
    pub ref_hub: [f32; DESIGN_MODES],
    /// The centrifugal term of the reference beam, per (rad/s)^2 of hub rate and per tick:
    /// `ts Mf^-1 S`, added to the reference beam's rates as `theta'^2 ref_s q`. At the
    /// speeds of a fast slew it changes the beam's stiffness by a fifth.
    pub ref_s: [[f32; DESIGN_MODES]; DESIGN_MODES],
    /// The reference beam's frequencies at rest, Hz (the model's hub-free modes,
    /// `ModalModel::pinned_hz`): where the drive's planner starts its search for a move that
    /// leaves the reference beam at rest (model-core's `planner::exact`).
    pub ref_hz: [f32; DESIGN_MODES],
    /// The centrifugal term in the observer's prediction on the hub, per (rad/s)^2 of hub
    /// rate and per tick: the hub's row of `ts M^-1 [0; S]`, the accelerations from `w^2 S
    /// q`. The modes' rows are `ref_s` (`M^-1`'s modal block is `Mf^-1`), which the observer
    /// reads there: the design holds each number once.
    pub obs_s_hub: [f32; DESIGN_MODES],
    /// The effective inertia Jeff = Mtt - h' Mqq^-1 h, kg m^2: the hub's with the beam's
    /// modes free (the sliding-mode laws' scale).
    pub jeff: f32,
    /// The rigid-body inertia Mtt, kg m^2: the feedforward `Mtt theta_r'' + c_v (theta_r' +
    /// ref_hub . q')` turns the hub, the beam and the payload along the reference.
    pub mtt: f32,
    /// The viscous friction c_v, N m s/rad.
    pub viscous: f32,
    /// The torque limit, N m: the observer is fed the torque the drive could apply.
    pub torque_limit_nm: f32,
    /// The identifier's beam: the modes with the hub clamped and turned by the measured
    /// angle, `Mqq q'' + Kqq q = -h theta''`, in `z = q + G theta` (`G = Mqq^-1 h`, which
    /// the drive finds from the reference beam's numbers) so that the angle drives it
    /// without its second derivative: `z'' = -Mqq^-1 Kqq q`. This is `ts^2 Mqq^-1
    /// Kqq`, the change per tick of `ts z'` per unit `q`, by rows (`[a00, a01, a10, a11]`).
    /// The drive runs it at the start of a move with its stiffness scaled by `1/lambda` and
    /// fits `lambda` to the gauge (the model's strain is about linear in it). Zero: the drive
    /// does not identify.
    pub id_a: [f32; DESIGN_MODES * DESIGN_MODES],
    /// The diagonal of `ts Mqq^-1 Cq`: the modes' damping in the identifier's beam, the
    /// change per tick of `ts z'` per unit `ts q'` (without it the fit took the damping's lag
    /// for stiffness, 1.6 % on the model's own beam; the payload's coupling of the modes'
    /// damping is left out).
    pub id_c: [f32; DESIGN_MODES],
}

impl LqgDesign {
    /// All zero: the design slot of a law without an observer.
    pub const ZERO: Self = LqgDesign {
        ad: [[0.0; MAX_STATES - 1]; MAX_STATES],
        bd: [0.0; MAX_STATES],
        strain_coef: [0.0; DESIGN_MODES],
        strain_omitted: 0.0,
        strain_omitted_rate: [0.0; DESIGN_MODES],
        strain_omitted_spin: [0.0; DESIGN_MODES],
        l: [[0.0; 2]; MAX_STATES],
        k: [0.0; MAX_STATES],
        k_move: [0.0; MAX_STATES],
        k_filter: 0.0,
        k_move_filter: 0.0,
        k_move_compliance: [0.0; MAX_STATES],
        k_move_filter_compliance: 0.0,
        count_interval: [0.0; 2],
        ki: 0.0,
        ref_ad: [[0.0; 2 * DESIGN_MODES]; 2 * DESIGN_MODES],
        ref_bd: [0.0; 2 * DESIGN_MODES],
        ref_hub: [0.0; DESIGN_MODES],
        ref_s: [[0.0; DESIGN_MODES]; DESIGN_MODES],
        ref_hz: [0.0; DESIGN_MODES],
        obs_s_hub: [0.0; DESIGN_MODES],
        jeff: 0.0,
        mtt: 0.0,
        viscous: 0.0,
        torque_limit_nm: 0.0,
        id_a: [0.0; DESIGN_MODES * DESIGN_MODES],
        id_c: [0.0; DESIGN_MODES],
    };

    /// `self + (other - self) f`, entry by entry: the gain scheduling a drive does between
    /// designs made at two payloads (the modal coordinates are the clamped beam's assumed
    /// modes, the same functions at every payload, so the entries mean the same in both).
    /// One loop over the design's entries, which are all `f32` ([`bytemuck::Pod`], `repr(C)`:
    /// a field of another type would be mixed as the `f32` its bits make, so the design
    /// holds none), and not inlined: a drive's schedule calls it three times, and the mix
    /// written field by field was 0.9 KB of a board's flash.
    #[inline(never)]
    pub fn mix(&self, other: &Self, f: f32) -> Self {
        let mut out = *self;
        let entries: &mut [f32] = bytemuck::cast_slice_mut(core::slice::from_mut(&mut out));
        for (a, b) in entries.iter_mut().zip(other.entries()) {
            *a += (b - *a) * f;
        }
        out
    }

    /// Every entry, in the fields' order: the design as one list of numbers.
    pub fn entries(&self) -> &[f32] {
        bytemuck::cast_slice(core::slice::from_ref(self))
    }
}

impl LqgWeights {
    /// The moving regulator's rate for a beam carrying `payload_kg`, 1/s (0: none).
    pub fn move_rate_at(&self, payload_kg: f64) -> f64 {
        let (loaded, unloaded) = (self.move_rate, self.move_rate_unloaded);
        if !(loaded > 0.0 && unloaded > loaded && self.move_rate_payload_kg > 0.0) {
            return loaded;
        }
        let f = (payload_kg / self.move_rate_payload_kg).clamp(0.0, 1.0);
        unloaded + (loaded - unloaded) * f
    }

    fn check(&self) -> Result<(), LqgError> {
        let pos = |v: f64| v.is_finite() && v > 0.0;
        let nonneg = |v: f64| v.is_finite() && v >= 0.0;
        if pos(self.kp)
            && pos(self.kd)
            && nonneg(self.ki)
            && nonneg(self.kq)
            && pos(self.sigma_nm)
            && nonneg(self.move_rate)
            && nonneg(self.move_rate_unloaded)
            && nonneg(self.move_rate_payload_kg)
            && nonneg(self.rest_kp)
            && pos(self.feedback_lowpass)
            && self.feedback_lowpass <= 1.0
        {
            Ok(())
        } else {
            Err(LqgError::Weights)
        }
    }
}

/// The inverse of the whole mass matrix `[[Mtt, h'], [h, Mqq]]`.
fn mass_inverse<const N: usize>(model: &ModalModel<N>) -> Option<Mat> {
    let nq = 1 + N;
    let mut m = ZERO;
    m[0][0] = model.mtt;
    for i in 0..N {
        m[0][1 + i] = model.h[i];
        m[1 + i][0] = model.h[i];
        for j in 0..N {
            m[1 + i][1 + j] = model.mqq[i][j];
        }
    }
    inverse(&m, nq)
}

/// The sampled model `(Ad, Bd)` of `model` at a tick of `ts_s`, given `minv`, the inverse
/// of its mass matrix.
fn sampled_with<const N: usize>(
    model: &ModalModel<N>,
    minv: &Mat,
    ts_s: f64,
) -> Option<(Mat, [f64; D])> {
    let nx = 2 + 2 * N;
    let nq = 1 + N;
    let mut k = ZERO;
    let mut c = ZERO;
    c[0][0] = model.beam.params().viscous_nms;
    for i in 0..N {
        for j in 0..N {
            k[1 + i][1 + j] = model.kqq[i][j];
            c[1 + i][1 + j] = model.cq[i][j];
        }
    }
    let mk = mul(minv, &k, nq);
    let mc = mul(minv, &c, nq);
    // Van Loan: exp([[A, B], [0, 0]] ts) = [[Ad, Bd], [0, 1]].
    let mut big = ZERO;
    for i in 0..nq {
        big[i][nq + i] = ts_s;
        for j in 0..nq {
            big[nq + i][j] = -mk[i][j] * ts_s;
            big[nq + i][nq + j] = -mc[i][j] * ts_s;
        }
        big[nq + i][nx] = minv[i][0] * ts_s;
    }
    let e = expm(&big, nx + 1);
    let mut ad = ZERO;
    let mut bd = [0.0; D];
    for i in 0..nx {
        for j in 0..nx {
            ad[i][j] = e[i][j];
        }
        bd[i] = e[i][nx];
    }
    Some((ad, bd))
}

/// The root strain of the modes past a design's [`DESIGN_MODES`], bent statically by a move
/// (their rows of the model, `Mqq q'' + Kqq q = -h theta'' + theta'^2 S q`, with their own
/// accelerations and their share of the centrifugal load left out, so that `K_oo q_o =
/// -h_o theta'' - M_od q_d'' + theta'^2 S_od q_d`, `o` the modes left out and `d` the
/// design's), read at the root.
///
/// From the model's own modes, not from the beam's exact statics: the drive expects what its
/// model says the beam bends by. The root strain's modal sum converges slowly (on the
/// aluminium beam the third mode holds 4.3e-8 per rad/s^2, the beam's exact root moment
/// 7.3e-8 more than the first two), and a drive that expected the beam's of a simulated
/// three-mode beam settled the exact 180 deg move 0.05 s later than fed the true state
/// (docs/design.md, section 4b).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct OmittedStrain {
    /// Per unit hub acceleration, rad/s^2.
    pub per_acc: f64,
    /// Per unit acceleration of each of the design's modes, m/s^2.
    pub per_mode_acc: [f64; DESIGN_MODES],
    /// Per (rad/s)^2 of hub rate, per unit of each of the design's modes, m.
    pub per_spin: [f64; DESIGN_MODES],
}

impl OmittedStrain {
    /// Of `model`: all zero if it has no modes past the design's, or its stiffness is
    /// singular.
    pub fn of<const N: usize>(model: &ModalModel<N>) -> Self {
        // `K_oo^-1` as the solve of the stiffness with the design's rows and columns made
        // the identity: a load on the modes left out bends only them.
        let mut k = model.kqq;
        for i in 0..N {
            for j in 0..N {
                if i < DESIGN_MODES || j < DESIGN_MODES {
                    k[i][j] = if i == j { 1.0 } else { 0.0 };
                }
            }
        }
        let Some(l) = crate::linalg::cholesky(&k) else {
            return Self::default();
        };
        // The root strain of the modes left out under a modal load `v` on them.
        let strain = |v: &dyn Fn(usize) -> f64| -> f64 {
            let load: [f64; N] =
                core::array::from_fn(|i| if i < DESIGN_MODES { 0.0 } else { v(i) });
            let q = crate::linalg::chol_solve(&l, &load);
            (DESIGN_MODES..N)
                .map(|i| model.root_strain_coef[i] * q[i])
                .sum()
        };
        Self {
            per_acc: strain(&|i| -model.h[i]),
            per_mode_acc: core::array::from_fn(|j| {
                if j < N {
                    strain(&|i| -model.mqq[i][j])
                } else {
                    0.0
                }
            }),
            per_spin: core::array::from_fn(|j| {
                if j < N {
                    strain(&|i| model.s[i][j])
                } else {
                    0.0
                }
            }),
        }
    }
}

/// [`design`] on `model`'s first [`DESIGN_MODES`] modes (a model with no more is designed on
/// as it is), expecting the strain of the modes past them ([`OmittedStrain`]): what a drive
/// is designed on.
pub fn design_leading<const N: usize>(
    model: &ModalModel<N>,
    weights: &LqgWeights,
    noise: &SensorNoise,
    ts_s: f64,
) -> Result<LqgDesign, LqgError> {
    let Some(leading) = leading_modes::<N, DESIGN_MODES>(model) else {
        return design(model, weights, noise, ts_s);
    };
    let mut d = design(&leading, weights, noise, ts_s)?;
    let omitted = OmittedStrain::of(model);
    d.strain_omitted = omitted.per_acc as f32;
    // Per change of the reference beam's mode rates over a tick: the hub's swing about the
    // rigid reference (`ref_hub`, `-h / Mtt`) and the modes' own accelerations.
    for j in 0..DESIGN_MODES {
        let swing = -leading.h[j] / leading.mtt;
        d.strain_omitted_rate[j] =
            ((omitted.per_acc * swing + omitted.per_mode_acc[j]) / ts_s) as f32;
        d.strain_omitted_spin[j] = omitted.per_spin[j] as f32;
    }
    Ok(d)
}

/// The model reduced to its first `M` modes (the leading rows and columns of each matrix;
/// the assumed modes are the clamped beam's, so this is the `M`-mode model of the same beam).
/// `Mqq^-1` and `Jeff` are those of the reduced model; the pinned frequencies are left as
/// the full model's. `None` if `M` exceeds `N` or the reduced mass matrix is singular.
pub fn leading_modes<const N: usize, const M: usize>(
    model: &ModalModel<N>,
) -> Option<ModalModel<M>> {
    if M == 0 || M > N {
        return None;
    }
    let v = |a: &[f64; N]| -> [f64; M] { core::array::from_fn(|i| a[i.min(N - 1)]) };
    let m = |a: &[[f64; N]; N]| -> [[f64; M]; M] {
        core::array::from_fn(|i| core::array::from_fn(|j| a[i.min(N - 1)][j.min(N - 1)]))
    };
    let mqq = m(&model.mqq);
    let mqq_inv = crate::linalg::spd_inverse(&mqq)?;
    let h = v(&model.h);
    let jeff = model.mtt - crate::linalg::quad(&h, &mqq_inv, &h);
    Some(ModalModel {
        beam: model.beam,
        shapes: core::array::from_fn(|i| model.shapes[i.min(N - 1)]),
        rho_kg_m: model.rho_kg_m,
        mtt: model.mtt,
        h,
        mqq,
        mqq_inv,
        kqq: m(&model.kqq),
        g: m(&model.g),
        s: m(&model.s),
        cq: m(&model.cq),
        jeff,
        clamped_hz: v(&model.clamped_hz),
        pinned_hz: v(&model.pinned_hz),
        root_strain_coef: v(&model.root_strain_coef),
        mid_strain_coef: v(&model.mid_strain_coef),
        tip_coef: v(&model.tip_coef),
    })
}

/// The stiffness, against the model's, that the drive's identifier may find (model-core's
/// `IDENTIFY_RANGE`: EI and density each within 20 % of the model's, so their ratio within
/// 2/3 to 3/2): the moving regulator is designed at both ends for its slope in the
/// compliance ([`LqgDesign::k_move_compliance`]).
pub const IDENTIFY_STIFFNESS: [f64; 2] = [2.0 / 3.0, 1.5];

/// `model` with its modes' stiffness scaled by `stiffness`, as the identifier reads a beam
/// (EI against the density): `Kqq` by the factor, and the modes' damping, which the model
/// makes in proportion to their frequencies, by its square root.
fn stiffened<const N: usize>(model: &ModalModel<N>, stiffness: f64) -> ModalModel<N> {
    let root = libm::sqrt(stiffness);
    let scale = |m: &crate::linalg::Mat<N>, f: f64| m.map(|row| row.map(|x| x * f));
    ModalModel {
        kqq: scale(&model.kqq, stiffness),
        cq: scale(&model.cq, root),
        clamped_hz: model.clamped_hz.map(|x| x * root),
        pinned_hz: model.pinned_hz.map(|x| x * root),
        ..*model
    }
}

/// Designs the observer and the state feedback for `model` sampled at `ts_s`: the continuous
/// model sampled, the regulator (`regulator`), the Kalman filter (`kalman`), both in the
/// drive's fixed layout, then the reference beam and the feedforward (`reference_beam`).
/// `model` has at most [`DESIGN_MODES`] modes, so nothing is expected of modes past them:
/// [`design_leading`] designs on a larger model's leading modes and expects the rest.
pub fn design<const N: usize>(
    model: &ModalModel<N>,
    weights: &LqgWeights,
    noise: &SensorNoise,
    ts_s: f64,
) -> Result<LqgDesign, LqgError> {
    weights.check()?;
    if N > DESIGN_MODES {
        return Err(LqgError::Modes);
    }
    if !(noise.theta_rad > 0.0 && noise.strain > 0.0 && ts_s > 0.0 && ts_s.is_finite()) {
        return Err(LqgError::Weights);
    }
    let nx = 2 + 2 * N;
    let minv = mass_inverse(model).ok_or(LqgError::Numerics)?;
    let (ad, bd) = sampled_with(model, &minv, ts_s).ok_or(LqgError::Numerics)?;
    // The hub angle's column is the unit vector, as no force depends on the angle: exactly,
    // since the matrix exponential only ever multiplies that column's zeros. The tick relies
    // on it (`LqgDesign::ad`).
    if (0..nx).any(|i| ad[i][0] != if i == 0 { 1.0 } else { 0.0 }) {
        return Err(LqgError::Numerics);
    }
    let rest = if weights.move_rate > 0.0 && weights.rest_kp > 0.0 {
        LqgWeights {
            kp: weights.rest_kp,
            ..*weights
        }
    } else {
        *weights
    };
    let kfull = regulator(model, &ad, &bd, &rest, ts_s, 0.0)?;
    let rate = weights.move_rate_at(model.beam.params().tip_mass_kg);
    let kmove = if rate > 0.0 {
        Some(regulator(model, &ad, &bd, weights, ts_s, rate)?)
    } else {
        None
    };
    // The moving regulator's share on the beam at each end of the stiffness the identifier
    // may find, and its secant in the compliance.
    let kmove_compliance = if rate > 0.0 && weights.identify {
        let share = |stiffness: f64| -> Result<([f64; D], f64), LqgError> {
            let m = stiffened(model, stiffness);
            let (ad, bd) = sampled_with(&m, &minv, ts_s).ok_or(LqgError::Numerics)?;
            let at_rest = regulator(&m, &ad, &bd, &rest, ts_s, 0.0)?;
            let moving = regulator(&m, &ad, &bd, weights, ts_s, rate)?;
            Ok((
                core::array::from_fn(|i| moving[i] - at_rest[i]),
                1.0 / stiffness - 1.0,
            ))
        };
        let [soft, stiff] = IDENTIFY_STIFFNESS;
        let ((a, ca), (b, cb)) = (share(soft)?, share(stiff)?);
        Some(core::array::from_fn::<f64, D, _>(|i| {
            (a[i] - b[i]) / (ca - cb)
        }))
    } else {
        None
    };
    let (pct, sinv) = kalman(model, &ad, &bd, weights, noise)?;
    let e = &model.root_strain_coef;

    let mut out = LqgDesign {
        ki: kfull[nx] as f32,
        k_filter: kfull[nx + 1] as f32,
        k_move_filter: kmove.map_or(0.0, |k| (k[nx + 1] - kfull[nx + 1]) as f32),
        k_move_filter_compliance: kmove_compliance.map_or(0.0, |k| k[nx + 1] as f32),
        jeff: model.jeff as f32,
        mtt: model.mtt as f32,
        viscous: model.beam.params().viscous_nms as f32,
        torque_limit_nm: model.beam.params().torque_limit_nm as f32,
        ..LqgDesign::ZERO
    };
    // From the model's layout to the fixed one.
    let at = |i: usize| {
        if i <= N {
            i
        } else {
            i - (1 + N) + (1 + DESIGN_MODES)
        }
    };
    for i in 0..nx {
        for j in 1..nx {
            out.ad[at(i)][at(j) - 1] = ad[i][j] as f32;
        }
        out.bd[at(i)] = bd[i] as f32;
        out.k[at(i)] = kfull[i] as f32;
        if let Some(kmove) = kmove {
            out.k_move[at(i)] = (kmove[i] - kfull[i]) as f32;
        }
        if let Some(kc) = kmove_compliance {
            out.k_move_compliance[at(i)] = kc[i] as f32;
        }
        for r in 0..2 {
            out.l[at(i)][r] = (pct[i][0] * sinv[0][r] + pct[i][1] * sinv[1][r]) as f32;
        }
    }
    for i in 0..N {
        out.strain_coef[i] = e[i] as f32;
    }
    if weights.count_interval && noise.encoder_step_rad.is_finite() {
        let step = noise.encoder_step_rad as f32;
        out.count_interval = [step.min(0.0), step.max(0.0)];
    }
    reference_beam(model, &minv, ts_s, &mut out);
    if weights.identify {
        identifier(model, ts_s, &mut out)?;
    }
    let finite = out
        .k
        .iter()
        .chain(out.l.iter().flatten())
        .all(|v| v.is_finite());
    if !finite || !out.ki.is_finite() {
        return Err(LqgError::Numerics);
    }
    Ok(out)
}

/// The state feedback on the sampled model `(ad, bd)` augmented with the integral of the hub
/// angle and the feedback low-pass's state: `K = (R + B'XB)^-1 B'XA` from the regulator's
/// Riccati equation, in the model's layout, then the integral's gain and the filter's; with
/// `rate > 0`, every closed-loop pole of the model and the filter left of `-rate`, 1/s.
fn regulator<const N: usize>(
    model: &ModalModel<N>,
    ad: &Mat,
    bd: &[f64; D],
    weights: &LqgWeights,
    ts_s: f64,
    rate: f64,
) -> Result<[f64; D], LqgError> {
    let nx = 2 + 2 * N;
    // Regulator on [x; z; f], z the integral of the hub angle error (z+ = z + ts theta)
    // and f the feedback low-pass's state, the filtered torque applied last tick: the
    // regulator's command `u` moves it to `f+ = (1 - a) f + a u`, which drives the plant
    // over the tick.
    let na = nx + 2;
    let (a, f) = (weights.feedback_lowpass, nx + 1);
    let mut aa = *ad;
    aa[nx][nx] = 1.0;
    aa[nx][0] = ts_s;
    let mut ba = [0.0; D];
    for i in 0..nx {
        aa[i][f] = bd[i] * (1.0 - a);
        ba[i] = bd[i] * a;
    }
    aa[f][f] = 1.0 - a;
    ba[f] = a;
    // A prescribed degree of stability: the regulator of `(e^(rate ts) A, e^(rate ts) B)`
    // holds that pair's poles inside the unit circle, so the true pair's lie within
    // `e^(-rate ts)`, left of `-rate` (Anderson and Moore). The integral's row is left as it
    // is: with `ki = 0` its pole stays where the small weight below puts it.
    let g = libm::exp(rate * ts_s);
    for i in (0..nx).chain([f]) {
        for j in (0..nx).chain([f]) {
            aa[i][j] *= g;
        }
        ba[i] *= g;
    }
    let mut q = ZERO;
    q[0][0] = weights.kp * weights.kp;
    q[1 + N][1 + N] = weights.kd * weights.kd;
    for i in 0..N {
        for j in 0..N {
            // The vibration energy 1/2 (q' Kqq q + q'' Mqq q'), weighted.
            q[1 + i][1 + j] = 0.5 * weights.kq * model.kqq[i][j];
            q[2 + N + i][2 + N + j] = 0.5 * weights.kq * model.mqq[i][j];
        }
    }
    // A small weight keeps the integral's pole off the unit circle when ki = 0. The
    // filter's state is not weighted: it is the torque, whose cost is R.
    q[nx][nx] = (weights.ki * weights.ki).max(1e-9);
    let mut g = ZERO;
    for i in 0..na {
        for j in 0..na {
            g[i][j] = ba[i] * ba[j]; // R = 1 (N m)^2
        }
    }
    let x = dare(&aa, &g, &q, na).ok_or(LqgError::Numerics)?;
    // K = (R + B'XB)^-1 B'XA
    let xb: [f64; D] = core::array::from_fn(|i| (0..na).map(|j| x[i][j] * ba[j]).sum());
    let bxb: f64 = (0..na).map(|i| ba[i] * xb[i]).sum();
    let kfull: [f64; D] =
        core::array::from_fn(|j| (0..na).map(|i| xb[i] * aa[i][j]).sum::<f64>() / (1.0 + bxb));
    Ok(kfull)
}

/// The current-estimate Kalman gain's two factors, `P C'` and `(C P C' + V)^-1`, for the
/// sampled model `(ad, bd)` measured by the encoder and the root gauge with `noise`.
#[allow(clippy::type_complexity)]
fn kalman<const N: usize>(
    model: &ModalModel<N>,
    ad: &Mat,
    bd: &[f64; D],
    weights: &LqgWeights,
    noise: &SensorNoise,
) -> Result<([[f64; 2]; D], [[f64; 2]; 2]), LqgError> {
    let nx = 2 + 2 * N;
    // Kalman filter: process noise through the input (sigma^2 b b') and a floor on every
    // state; measurement noise of the sensors.
    let e = &model.root_strain_coef;
    let mut crow = [[0.0; D]; 2];
    crow[0][0] = 1.0;
    crow[1][1..=N].copy_from_slice(&e[..N]);
    let vinv = [
        1.0 / (noise.theta_rad * noise.theta_rad),
        1.0 / (noise.strain * noise.strain),
    ];
    let mut w = ZERO;
    let s2 = weights.sigma_nm * weights.sigma_nm;
    for i in 0..nx {
        for j in 0..nx {
            w[i][j] = s2 * bd[i] * bd[j];
        }
        w[i][i] += 1e-6 * s2 * bd[i] * bd[i] + 1e-18;
    }
    let mut gk = ZERO;
    for i in 0..nx {
        for j in 0..nx {
            gk[i][j] = (0..2).map(|r| crow[r][i] * vinv[r] * crow[r][j]).sum();
        }
    }
    let p = dare(&transpose(ad, nx), &gk, &w, nx).ok_or(LqgError::Numerics)?;
    // L = P C' (C P C' + V)^-1, the current-estimate gain.
    let pct: [[f64; 2]; D] = core::array::from_fn(|i| {
        core::array::from_fn(|r| (0..nx).map(|j| p[i][j] * crow[r][j]).sum())
    });
    let mut s = [[0.0; 2]; 2];
    for (r1, row) in s.iter_mut().enumerate() {
        for (r2, v) in row.iter_mut().enumerate() {
            *v = (0..nx).map(|i| crow[r1][i] * pct[i][r2]).sum::<f64>();
        }
        row[r1] += 1.0 / vinv[r1];
    }
    let det = s[0][0] * s[1][1] - s[0][1] * s[1][0];
    if !(det.is_finite() && det != 0.0) {
        return Err(LqgError::Numerics);
    }
    let sinv = [
        [s[1][1] / det, -s[0][1] / det],
        [-s[1][0] / det, s[0][0] / det],
    ];
    Ok((pct, sinv))
}

/// The identifier's clamped beam ([`LqgDesign::id_a`], [`LqgDesign::id_g`]) into `out`.
fn identifier<const N: usize>(
    model: &ModalModel<N>,
    ts_s: f64,
    out: &mut LqgDesign,
) -> Result<(), LqgError> {
    let mut m = ZERO;
    for i in 0..N {
        for j in 0..N {
            m[i][j] = model.mqq[i][j];
        }
    }
    let mi = inverse(&m, N).ok_or(LqgError::Numerics)?;
    for i in 0..N {
        for j in 0..N {
            let mk: f64 = (0..N).map(|l| mi[i][l] * model.kqq[l][j]).sum();
            out.id_a[i * DESIGN_MODES + j] = (mk * ts_s * ts_s) as f32;
        }
        out.id_c[i] = ((0..N).map(|l| mi[i][l] * model.cq[l][i]).sum::<f64>() * ts_s) as f32;
    }
    Ok(())
}

/// The reference beam (the hub-free beam driven by the reference's rigid acceleration),
/// sampled, into `out`. `minv` is the mass matrix's inverse, whose modes' block is `Mf^-1`.
fn reference_beam<const N: usize>(
    model: &ModalModel<N>,
    minv: &Mat,
    ts_s: f64,
    out: &mut LqgDesign,
) {
    // The torque Mtt a turns the rigid body by a; what is left of the hub's equation, Mtt
    // theta_f'' + h' q'' = 0 (the viscous term on theta_f' is the feedforward's), makes the
    // hub turn by theta_f = -h' q / Mtt about it, and the modes' equation becomes Mf q'' + Cq
    // q' + Kqq q = -h a. Sampled by Van Loan as above: z = [q; q'], z' = [[0, I], [-Mf^-1
    // Kqq, -Mf^-1 Cq]] z + [0; -Mf^-1 h] a.
    let mf = |i: usize, l: usize| minv[1 + i][1 + l];
    let mut big = ZERO;
    let n2 = 2 * N;
    for i in 0..N {
        big[i][N + i] = ts_s;
        for j in 0..N {
            let (mut mk, mut mc) = (0.0, 0.0);
            for l in 0..N {
                mk += mf(i, l) * model.kqq[l][j];
                mc += mf(i, l) * model.cq[l][j];
            }
            big[N + i][j] = -mk * ts_s;
            big[N + i][N + j] = -mc * ts_s;
        }
        big[N + i][n2] = -(0..N).map(|l| mf(i, l) * model.h[l]).sum::<f64>() * ts_s;
    }
    let e_ref = expm(&big, n2 + 1);
    let rat = |i: usize| if i < N { i } else { i - N + DESIGN_MODES };
    for i in 0..n2 {
        for j in 0..n2 {
            out.ref_ad[rat(i)][rat(j)] = e_ref[i][j] as f32;
        }
        out.ref_bd[rat(i)] = e_ref[i][n2] as f32;
    }
    for i in 0..N {
        out.ref_hz[i] = model.pinned_hz[i] as f32;
        out.ref_hub[i] = (-model.h[i] / model.mtt) as f32;
        for j in 0..N {
            out.ref_s[i][j] = ((0..N).map(|l| mf(i, l) * model.s[l][j]).sum::<f64>() * ts_s) as f32;
        }
    }
    for j in 0..N {
        out.obs_s_hub[j] =
            ((0..N).map(|l| minv[0][1 + l] * model.s[l][j]).sum::<f64>() * ts_s) as f32;
    }
}

#[cfg(test)]
mod tests;
