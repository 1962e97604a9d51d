//! The strain-augmented SMC: the sliding-mode law on the blended output
//! `y = theta + c eps_root`, optionally with the model terms of the beam.

use super::{
    gains, input_gain_ratio, ControlLaw, Estimate, LawGains, LawPlant, LawState, Switching,
};
use crate::beam::ParamError;
use crate::modal::MAX_MODES;
use crate::plant::PlantPoint;
use crate::spline::RefPoint;

gains! {
    /// The strain-augmented SMC's gains: the sliding-mode gains on y = theta + c eps_root.
    pub struct StrainSmcGains for SmcStrain {
        /// Surface slope W, 1/s.
        w,
        /// Switching gain A, rad/s^2.
        a,
        /// Boundary-layer slope beta, s/rad.
        beta,
        /// Strain blend c, rad per unit strain: y = theta + c eps_root.
        c,
    }
    settings {
        /// Switching function.
        switching: Switching = Switching,
        /// Keep the model terms C M^-1 (N + K) with q estimated from the root strain.
        model_terms: bool = ModelTerms,
    }
}

/// `C M^-1 (N + K)` with q = [q1, 0, ..] from the root strain, reduced to scalars.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(super) struct ModelTerms {
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

impl LawGains for StrainSmcGains {
    /// Picked by hand as the paper's SMC was, on the aluminium preset with 3 modes.
    const START: Self = StrainSmcGains {
        w: 10.0,
        a: 600.0,
        beta: 0.1,
        c: 10.0,
        switching: Switching::Tanh,
        model_terms: false,
    };

    /// The strain law's constants. With x = [theta; q], M0 = M(q = 0) and the output row
    /// C = [1, c e'] (e the root strain coefficients), block inversion gives
    /// C M0^-1 B = (1 - c gamma) / Jeff with gamma = e' Mqq^-1 h, and the row
    /// C M0^-1 = [r_theta, r_q] with r_theta = (1 - c gamma)/Jeff and
    /// r_q = c e' Mqq^-1 - r_theta h' Mqq^-1.
    fn build(
        &self,
        plain: ControlLaw,
        m: &PlantPoint,
        _: &impl LawPlant,
    ) -> Result<ControlLaw, ParamError> {
        let c = self.c;
        let e = m.root_strain_coef;
        let ratio = input_gain_ratio(c, m)?;
        let r_theta = ratio / m.jeff;
        // Past the model's modes every vector is zero, and so is each added term.
        let r_q: [f32; MAX_MODES] =
            core::array::from_fn(|j| c * m.minv_e[j] - r_theta * m.minv_h[j]);
        let col0 = |a: &[f32; MAX_MODES]| (0..MAX_MODES).map(|j| r_q[j] * a[j]).sum::<f32>();
        let model = if self.model_terms && e[0].abs() > 0.0 {
            ModelTerms {
                enabled: true,
                q_per_strain: 1.0 / e[0],
                r_theta,
                viscous: m.viscous_nms,
                s11: m.s_col0[0],
                k_sum: col0(&m.kqq_col0),
                c_sum: col0(&m.cq_col0),
                s_sum: col0(&m.s_col0),
            }
        } else {
            ModelTerms::default()
        };
        Ok(ControlLaw {
            inertia: 1.0 / r_theta,
            model,
            ..plain
        })
    }

    #[inline(always)]
    fn torque_nm(
        &self,
        law: &ControlLaw,
        x: &Estimate,
        r: &RefPoint,
        _: &mut LawState,
        _: f32,
    ) -> f32 {
        let c = self.c;
        let y = x.theta + c * x.strain;
        let dy = x.omega + c * x.strain_rate;
        let (e, de) = (y - r.pos, dy - r.vel);
        let s = self.w * e + de;
        let mut v = r.acc - self.w * de - self.a * self.switching.apply(self.beta * s);
        let m = &law.model;
        if m.enabled {
            let (q, dq) = (x.strain * m.q_per_strain, x.strain_rate * m.q_per_strain);
            let w = x.omega;
            v += m.r_theta * (2.0 * w * m.s11 * q * dq + m.viscous * w)
                + (m.k_sum - w * w * m.s_sum) * q
                + m.c_sum * dq;
        }
        law.inertia * v
    }
}
