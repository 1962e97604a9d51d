//! The nonlinear slewing-beam plant of docs/design.md, section 2, in `f64`.
//!
//! ```text
//! [Mtt + q'Sq] theta'' + h'q'' + 2 theta' q'Sq' + b theta' + friction = tau
//! h theta'' + Mqq q'' + Cq q' + (Kqq - theta'^2 S) q = 0
//! ```
//!
//! Because Mqq is constant, block elimination solves the accelerations without a general
//! linear solve: `theta'' = (f_theta - h'Mqq^-1 f_q) / (Jeff + q'Sq)` and
//! `q'' = Mqq^-1 (f_q - h theta'')`. The denominator is the hub's effective inertia, which is
//! also what the validity guard watches. Two integrators: fixed-step RK4 (fast; used by the
//! runner) and the adaptive 8th-order Dormand-Prince of the `ode_solvers` crate (the accuracy
//! reference the tests compare RK4 with).

use model_core::linalg::{dot, mat_vec, quad};
use model_core::ModalModel;
use ode_solvers::{DVector, Dop853, System};

/// Why the reference integrator could not advance the plant.
#[derive(Debug, thiserror::Error)]
pub enum IntegrationError {
    /// DOP853 gave up (too many steps, step-size underflow, stiffness).
    #[error("the reference integrator stopped")]
    Stopped(#[from] ode_solvers::dop_shared::IntegrationError),
    /// It returned without a final state.
    #[error("the reference integrator returned no state")]
    NoOutput,
}

/// Velocity scale of the Coulomb friction's smooth sign, rad/s: `Fc tanh(omega / eps)`.
pub const COULOMB_SMOOTHING_RAD_S: f64 = 1e-3;

/// Plant state: hub angle and rate, modal coordinates and rates.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct State<const N: usize> {
    /// Hub angle theta, rad.
    pub theta: f64,
    /// Hub rate theta', rad/s.
    pub omega: f64,
    /// Modal coordinates q, m.
    pub q: [f64; N],
    /// Modal rates q', m/s.
    pub qd: [f64; N],
}

impl<const N: usize> State<N> {
    /// At rest at `theta`, undeformed.
    pub fn at_rest(theta: f64) -> Self {
        Self {
            theta,
            omega: 0.0,
            q: [0.0; N],
            qd: [0.0; N],
        }
    }

    /// `self + k * d`, component-wise.
    fn add_scaled(&self, d: &Self, k: f64) -> Self {
        Self {
            theta: self.theta + k * d.theta,
            omega: self.omega + k * d.omega,
            q: core::array::from_fn(|i| self.q[i] + k * d.q[i]),
            qd: core::array::from_fn(|i| self.qd[i] + k * d.qd[i]),
        }
    }

    /// True when every component is finite.
    pub fn is_finite(&self) -> bool {
        self.theta.is_finite()
            && self.omega.is_finite()
            && self.q.iter().chain(&self.qd).all(|v| v.is_finite())
    }

    fn to_vector(self) -> DVector<f64> {
        let mut v = DVector::zeros(2 + 2 * N);
        v[0] = self.theta;
        v[1] = self.omega;
        for i in 0..N {
            v[2 + i] = self.q[i];
            v[2 + N + i] = self.qd[i];
        }
        v
    }

    fn from_vector(v: &DVector<f64>) -> Self {
        Self {
            theta: v[0],
            omega: v[1],
            q: core::array::from_fn(|i| v[2 + i]),
            qd: core::array::from_fn(|i| v[2 + N + i]),
        }
    }
}

/// Physical outputs at one instant.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Outputs {
    /// Root strain (at the root gauge), dimensionless.
    pub root_strain: f64,
    /// Mid-span strain, dimensionless.
    pub mid_strain: f64,
    /// Tip deflection in the hub frame, m.
    pub w_tip: f64,
    /// Tip angle theta + w_tip / (r + L), rad.
    pub tip_angle: f64,
}

/// Why the second-order model stopped being valid.
#[derive(Clone, Debug, PartialEq)]
pub enum Breakdown {
    /// The tip deflected more than half the beam length.
    TipDeflection {
        /// |w_tip|, m.
        w_tip_m: f64,
        /// The limit, m.
        limit_m: f64,
    },
    /// The effective hub inertia Jeff + q'Sq fell below a tenth of Jeff.
    EffectiveInertia {
        /// Jeff + q'Sq, kg m^2.
        inertia: f64,
        /// Jeff, kg m^2.
        jeff: f64,
    },
    /// The state became NaN or infinite.
    NonFinite,
}

impl std::fmt::Display for Breakdown {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Breakdown::TipDeflection { w_tip_m, limit_m } => write!(
                f,
                "tip deflection {:.3} m exceeds {:.3} m (half the beam): the second-order model no longer holds",
                w_tip_m, limit_m
            ),
            Breakdown::EffectiveInertia { inertia, jeff } => write!(
                f,
                "effective hub inertia Jeff + q'Sq = {inertia:.3e} fell below a tenth of Jeff = {jeff:.3e}"
            ),
            Breakdown::NonFinite => write!(f, "the plant state became non-finite"),
        }
    }
}

/// The plant: the modal model plus friction and the drive's torque limit.
#[derive(Clone, Copy, Debug)]
pub struct Plant<const N: usize> {
    /// The modal model (matrices, damping, gauges).
    pub model: ModalModel<N>,
    minv_h: [f64; N],
    viscous: f64,
    coulomb: f64,
    coulomb_asym: f64,
    torque_limit: f64,
}

impl<const N: usize> Plant<N> {
    /// The plant for `model`, with the friction and torque limit of its beam parameters.
    pub fn new(model: ModalModel<N>) -> Self {
        let p = *model.beam.params();
        Self {
            minv_h: mat_vec(&model.mqq_inv, &model.h),
            viscous: p.viscous_nms,
            coulomb: p.coulomb_nm,
            coulomb_asym: p.coulomb_asym_nm,
            torque_limit: p.torque_limit_nm,
            model,
        }
    }

    /// The same plant with friction and modal damping turned off (for conservation checks).
    pub fn lossless(mut self) -> Self {
        self.viscous = 0.0;
        self.coulomb = 0.0;
        self.coulomb_asym = 0.0;
        self.model.cq = [[0.0; N]; N];
        self
    }

    /// The torque the drive actually delivers for a command: saturated, NaN taken as zero.
    pub fn saturate(&self, tau: f64) -> f64 {
        if tau.is_nan() {
            0.0
        } else {
            tau.clamp(-self.torque_limit, self.torque_limit)
        }
    }

    /// Time derivative of the state under hub torque `tau` (already saturated).
    pub fn derivative(&self, x: &State<N>, tau: f64) -> State<N> {
        let m = &self.model;
        let w = x.omega;
        let sq = mat_vec(&m.s, &x.q);
        let q_s_q = dot(&x.q, &sq);
        let q_s_qd = dot(&sq, &x.qd);
        // Coulomb friction by direction: `Fc + Fa` turning positive, `Fc - Fa` negative.
        let sign = (w / COULOMB_SMOOTHING_RAD_S).tanh();
        let friction = self.viscous * w + self.coulomb * sign + self.coulomb_asym * sign.abs();
        let f_theta = tau - 2.0 * w * q_s_qd - friction;
        let cqd = mat_vec(&m.cq, &x.qd);
        let kq = mat_vec(&m.kqq, &x.q);
        let f_q: [f64; N] = core::array::from_fn(|i| -cqd[i] - kq[i] + w * w * sq[i]);
        let theta_dd = (f_theta - dot(&self.minv_h, &f_q)) / (m.jeff + q_s_q);
        let rhs: [f64; N] = core::array::from_fn(|i| f_q[i] - m.h[i] * theta_dd);
        let q_dd = mat_vec(&m.mqq_inv, &rhs);
        State {
            theta: w,
            omega: theta_dd,
            q: x.qd,
            qd: q_dd,
        }
    }

    /// The beam's modal accelerations with the hub's motion prescribed: rate `omega` and
    /// acceleration `alpha` (the hub follows them whatever the torque; friction and the
    /// hub's own equation drop out). The rows of [`Plant::derivative`] for `q`.
    pub fn flex_acceleration(
        &self,
        q: &[f64; N],
        qd: &[f64; N],
        omega: f64,
        alpha: f64,
    ) -> [f64; N] {
        let m = &self.model;
        let sq = mat_vec(&m.s, q);
        let cqd = mat_vec(&m.cq, qd);
        let kq = mat_vec(&m.kqq, q);
        let rhs: [f64; N] =
            core::array::from_fn(|i| -cqd[i] - kq[i] + omega * omega * sq[i] - m.h[i] * alpha);
        mat_vec(&m.mqq_inv, &rhs)
    }

    /// The longest RK4 step that stays well inside the method's stability region for this
    /// plant, s: the fastest mode (`h omega_max <= 1`) and, with Coulomb friction, its smooth
    /// sign near rest, whose slope `Fc / eps` over the hub's inertia is a stiff real
    /// eigenvalue (`h lambda <= 1`; RK4 is stable to 2.78). For a hub at rest with
    /// 0.04 N m of Coulomb friction that is about 0.2 ms.
    pub fn stable_step_s(&self) -> f64 {
        let m = &self.model;
        let omega_max = m
            .pinned_hz
            .iter()
            .fold(0.0f64, |a, &f| a.max(2.0 * core::f64::consts::PI * f));
        let lambda_friction = ((self.coulomb + self.coulomb_asym.abs()) / COULOMB_SMOOTHING_RAD_S
            + self.viscous)
            / m.jeff;
        let lambda = omega_max.max(lambda_friction);
        if lambda > 0.0 {
            1.0 / lambda
        } else {
            f64::INFINITY
        }
    }

    /// One classical RK4 step of length `h` with constant torque `tau`.
    pub fn rk4_step(&self, x: &State<N>, tau: f64, h: f64) -> State<N> {
        let k1 = self.derivative(x, tau);
        let k2 = self.derivative(&x.add_scaled(&k1, 0.5 * h), tau);
        let k3 = self.derivative(&x.add_scaled(&k2, 0.5 * h), tau);
        let k4 = self.derivative(&x.add_scaled(&k3, h), tau);
        let mut out = x.add_scaled(&k1, h / 6.0);
        out = out.add_scaled(&k2, h / 3.0);
        out = out.add_scaled(&k3, h / 3.0);
        out.add_scaled(&k4, h / 6.0)
    }

    /// Integrates over `dt` with constant torque `tau` using the adaptive DOP853 reference
    /// integrator at tolerances `rtol`, `atol`; the integrator's complaint if it fails.
    pub fn dop853(
        &self,
        x: &State<N>,
        tau: f64,
        dt: f64,
        rtol: f64,
        atol: f64,
    ) -> Result<State<N>, IntegrationError> {
        let sys = Held { plant: *self, tau };
        let mut stepper = Dop853::new(sys, 0.0, dt, dt, x.to_vector(), rtol, atol);
        stepper.integrate()?;
        stepper
            .y_out()
            .last()
            .map(State::from_vector)
            .ok_or(IntegrationError::NoOutput)
    }

    /// Kinetic plus strain energy T + V, J.
    pub fn energy(&self, x: &State<N>) -> f64 {
        let m = &self.model;
        let w = x.omega;
        let t = 0.5
            * (w * w * (m.mtt + quad(&x.q, &m.s, &x.q))
                + 2.0 * w * dot(&m.h, &x.qd)
                + quad(&x.qd, &m.mqq, &x.qd));
        t + 0.5 * quad(&x.q, &m.kqq, &x.q)
    }

    /// Angular momentum about the hub axis, dT/dtheta', kg m^2/s.
    pub fn angular_momentum(&self, x: &State<N>) -> f64 {
        let m = &self.model;
        x.omega * (m.mtt + quad(&x.q, &m.s, &x.q)) + dot(&m.h, &x.qd)
    }

    /// Strains, tip deflection and tip angle.
    pub fn outputs(&self, x: &State<N>) -> Outputs {
        let m = &self.model;
        let p = m.beam.params();
        let w_tip = dot(&m.tip_coef, &x.q);
        Outputs {
            root_strain: dot(&m.root_strain_coef, &x.q),
            mid_strain: dot(&m.mid_strain_coef, &x.q),
            w_tip,
            tip_angle: x.theta + w_tip / (p.hub_radius_m + p.length_m),
        }
    }

    /// `Err` when the state has left the range where the second-order model holds.
    pub fn check_validity(&self, x: &State<N>) -> Result<(), Breakdown> {
        if !x.is_finite() {
            return Err(Breakdown::NonFinite);
        }
        let m = &self.model;
        let limit_m = 0.5 * m.beam.params().length_m;
        let w_tip_m = dot(&m.tip_coef, &x.q).abs();
        if w_tip_m > limit_m {
            return Err(Breakdown::TipDeflection { w_tip_m, limit_m });
        }
        let inertia = m.jeff + quad(&x.q, &m.s, &x.q);
        if inertia < 0.1 * m.jeff {
            return Err(Breakdown::EffectiveInertia {
                inertia,
                jeff: m.jeff,
            });
        }
        Ok(())
    }
}

/// The plant with its torque held constant, as an `ode_solvers` system.
struct Held<const N: usize> {
    plant: Plant<N>,
    tau: f64,
}

impl<const N: usize> System<f64, DVector<f64>> for Held<N> {
    fn system(&self, _t: f64, y: &DVector<f64>, dy: &mut DVector<f64>) {
        let d = self.plant.derivative(&State::from_vector(y), self.tau);
        dy.copy_from(&d.to_vector());
    }
}
