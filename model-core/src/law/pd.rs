//! The PD baseline: `tau = Kp (theta_r - theta) + Kd (theta_r' - theta')`.

use super::{gains, ControlLaw, Estimate, LawGains, LawState};
use crate::spline::RefPoint;

gains! {
    /// PD gains: `tau = Kp (theta_r - theta) + Kd (theta_r' - theta')`.
    pub struct PdGains for Pd {
        /// Proportional gain, N m/rad.
        kp,
        /// Derivative gain, N m s/rad.
        kd,
    }
}

impl PdGains {
    /// The paper's calibration controller and our baseline: Kp 20, Kd 1.
    pub const BASELINE: PdGains = PdGains { kp: 20.0, kd: 1.0 };
}

impl LawGains for PdGains {
    const START: Self = Self::BASELINE;

    #[inline(always)]
    fn torque_nm(
        &self,
        _: &ControlLaw,
        x: &Estimate,
        r: &RefPoint,
        _: &mut LawState,
        _: f32,
    ) -> f32 {
        self.kp * (r.pos - x.theta) + self.kd * (r.vel - x.omega)
    }
}
