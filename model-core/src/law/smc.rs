//! The paper's sliding-mode controller on the hub angle.

use super::{gains, ControlLaw, Estimate, LawGains, LawState, Switching};
use crate::spline::RefPoint;

gains! {
    /// Sliding-mode gains: `s = W e + e'`, `tau = J (theta_r'' - W e' - A f(beta s))`.
    pub struct SmcGains for Smc {
        /// Surface slope W, 1/s: s = W e + e'.
        w,
        /// Switching gain A, rad/s^2.
        a,
        /// Boundary-layer slope beta, s/rad.
        beta,
    }
    settings {
        /// Switching function.
        switching: Switching = Switching,
    }
}

impl LawGains for SmcGains {
    /// Picked by hand for the aluminium preset with 3 modes: a grid over W, A, beta ranked
    /// by the tip's settling time (docs/use-the-cli.md, "Control laws and the hand-picked
    /// gains").
    const START: Self = SmcGains {
        w: 10.0,
        a: 1000.0,
        beta: 0.1,
        switching: Switching::Tanh,
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
        let (e, de) = (x.theta - r.pos, x.omega - r.vel);
        let s = self.w * e + de;
        law.inertia * (r.acc - self.w * de - self.a * self.switching.apply(self.beta * s))
    }
}

#[cfg(test)]
mod tests {
    use super::super::tests::{model, strain, GAINS};
    use super::*;
    use crate::law::Law;

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
}
