//! Rigid-body feedforward plus PD: the practical peer, usually run with a shaped reference.

use super::{gains, ControlLaw, Estimate, LawGains, LawState, PdGains};
use crate::spline::RefPoint;

gains! {
    /// Feedforward-plus-PD gains: `tau = Mtt theta_r'' + Kp (theta_r - theta) + Kd
    /// (theta_r' - theta')`, with Mtt the whole rigid inertia (hub, beam and payload) about
    /// the axis.
    pub struct PdFfGains for PdFf {
        /// Proportional gain, N m/rad.
        kp,
        /// Derivative gain, N m s/rad.
        kd,
    }
}

impl LawGains for PdFfGains {
    /// The PD baseline's gains under the feedforward.
    const START: Self = PdFfGains {
        kp: PdGains::BASELINE.kp,
        kd: PdGains::BASELINE.kd,
    };

    #[inline(always)]
    fn torque_nm(
        &self,
        law: &ControlLaw,
        x: &Estimate,
        r: &RefPoint,
        _: &mut LawState,
        _: f32,
    ) -> f32 {
        law.rigid_inertia * r.acc + self.kp * (r.pos - x.theta) + self.kd * (r.vel - x.omega)
    }
}
