//! The integral sliding mode with rigid-body feedforward: continuous, and it rejects a
//! constant load up to the switching gain times Jeff.

use super::{
    gains, input_gain_ratio, integral_bound, integrate, ControlLaw, Estimate, LawGains, LawPlant,
    LawState, Switching,
};
use crate::beam::ParamError;
use crate::plant::PlantPoint;
use crate::spline::RefPoint;

gains! {
    /// Integral sliding-mode gains. On the output `y = theta + c eps_root` (c = 0: the hub
    /// angle), with `e = y - theta_r` and `z` its integral over the move, the surface is
    /// `s = e' + W e + Wi z` and `tau = Mtt theta_r'' - Jc (W e' + Wi e + A f(beta s))`,
    /// where `Jc = [C M^-1 B]^-1` is Jeff for c = 0 and `Jeff / (1 - c gamma)` with the
    /// blend (as for smc-strain). On `s = 0` the error obeys `e'' + W e' + Wi e = 0`; a
    /// constant load `d` with `|d| < Jc A` is absorbed by `z`, so the output returns to the
    /// reference under it, and the strain blend lets the sliding motion damp the beam.
    pub struct SmcIGains for SmcI {
        /// Surface slope W, 1/s.
        w,
        /// Integral slope Wi, 1/s^2.
        wi,
        /// Switching gain A, rad/s^2: `Jc A` is the largest load the drive holds.
        a,
        /// Boundary-layer slope beta, s/rad.
        beta,
        /// Strain blend c, rad per unit strain (0: the surface is on the hub angle alone).
        c,
    }
    settings {
        /// Switching function.
        switching: Switching = Switching,
    }
}

impl LawGains for SmcIGains {
    /// The hand-picked SMC's surface with a critically damped integral (Wi = W^2/4) and A
    /// sized so that Jeff A (0.72 N m on the aluminium beam) exceeds the 0.5 N m load the
    /// drive must hold.
    const START: Self = SmcIGains {
        w: 10.0,
        wi: 25.0,
        a: 100.0,
        beta: 0.1,
        c: 0.0,
        switching: Switching::Tanh,
    };

    fn build(
        &self,
        plain: ControlLaw,
        m: &PlantPoint,
        _: &impl LawPlant,
    ) -> Result<ControlLaw, ParamError> {
        // The blended output's input gain, as for smc-strain (Jeff when c = 0).
        let jc = m.jeff / input_gain_ratio(self.c, m)?;
        // Jc A beta Wi |z| <= the drive's limit (infinite without integral action).
        let per_z = jc * (self.a * self.beta * self.wi);
        Ok(ControlLaw {
            inertia: jc,
            integral_max: integral_bound(m.torque_limit_nm, per_z),
            ..plain
        })
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
        let g = self;
        let y = x.theta + g.c * x.strain;
        let dy = x.omega + g.c * x.strain_rate;
        let (e, de) = (y - r.pos, dy - r.vel);
        state.integral = integrate(state.integral, e, ts_s, law.integral_max);
        let s = de + g.w * e + g.wi * state.integral;
        law.rigid_inertia * r.acc
            - law.inertia * (g.w * de + g.wi * e + g.a * g.switching.apply(g.beta * s))
    }
}

#[cfg(test)]
mod tests {
    use super::super::tests::model;
    use super::*;
    use crate::law::Law;

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
}
