//! The paper's sliding mode carried to the full state: the sliding surface is the LQR's
//! combination of the observed hub and flexible modes (about the reference state), and the
//! switching term acts along it. The observer, the reference beam and the feedforward are
//! the LQG law's (`super::lqg`); like it, the law is built on a modal model on the host only,
//! behind model-core's `observer` feature.
//!
//! With `K` the LQR gain designed for the weights (hub stiffness `kp`, vibration energy `kq`,
//! no integral) and `x - x_ref` the observed state's error from the reference state, the
//! surface is `s = K (x - x_ref) / K_rate` (rad/s: the hub rate error plus the hub angle's,
//! the modes' and their rates' errors weighted as the LQR weighs them), and
//!
//! `tau = ff - K (x - x_ref) - Jeff A f(beta s)`.
//!
//! On `s = 0` the hub follows the dynamics the LQR leaves it with, which damp the modes; the
//! linear term is the equivalent control that keeps it there on the model, and the switching
//! term drives it back against what the model does not know (friction, a load, a hub-side
//! parameter error), up to `Jeff A` N m. Within the boundary layer (`|beta s|` small) the law
//! is the LQR with its gain raised by `1 + Jeff A beta / K_rate`; outside, the LQR plus a
//! bounded push of `Jeff A`. With `A = 0` it is the LQR without integral.

#[cfg(feature = "observer")]
use super::lqg::DesignOptions;
use super::{gains, ControlLaw, Estimate, LawGains, LawPlant, LawState, LqgGains, Switching};
use crate::beam::ParamError;
#[cfg(feature = "observer")]
use crate::beam::ParamErrorKind;
use crate::plant::PlantPoint;
use crate::spline::RefPoint;

gains! {
    /// Full-state sliding-mode gains: the surface from an LQR design (`kp`, `kq`, with the
    /// hub rate weight [`SMC_MODAL_KD`] and no integral), its observer's `sigma`, and the
    /// paper's switching gain and boundary layer.
    pub struct SmcModalGains for SmcModal {
        /// Hub angle weight of the surface's LQR design, as a stiffness, N m/rad.
        kp,
        /// Weight on the beam's vibration energy in the surface's design, (N m)^2/J.
        kq,
        /// Disturbance torque the observer assumes, N m.
        sigma,
        /// Switching gain A, rad/s^2: the switching term reaches `Jeff A` N m.
        a,
        /// Boundary-layer slope beta, s/rad.
        beta,
    }
    settings {
        /// Switching function.
        switching: Switching = Switching,
    }
}

/// The hub rate weight of the surface's LQR design, N m s/rad: the LQG rows' (the surface's
/// slope is set by `kp` against it).
pub const SMC_MODAL_KD: f32 = 1.0;

/// The degree of stability of the regulator the law runs while the reference moves and for
/// a while after it stops (`law::MOVE_FADE_S`, with the `observer` feature), 1/s
/// (`beam_model::lqg::LqgWeights::move_rate`): every closed-loop pole of the nominal model
/// left of -12 1/s.
///
/// The surface's own regulator leaves a pair of poles at about -11 +- 20j 1/s (3.6 Hz,
/// damping 0.47): the hub creeps into its band after a move and a beam off the model rings
/// slowly through the tail. Before the drive identified the beam's stiffness, 5 1/s was as
/// fast as beams 20 % off the model allowed (at 8-35 1/s the observer's nominal model lost
/// 1-88 of 200). With the identifier, over 200 such beams on seven seeds, 12 1/s took the
/// p95 down at every move length (at 180 deg 0.81-0.89 s -> 0.70-0.72 s,
/// docs/identification.md). The faster loop bends soft, heavy beams further (2041-2123 ue at
/// 180 deg without the strain budget, [`SmcModalGains::PLANNED_STRAIN`]); at 14-15 1/s the
/// 90 deg p95 grew again (0.59-0.64 s against 0.58-0.61 s). This is the rate from
/// [`SMC_MODAL_MOVE_RATE_PAYLOAD_KG`] of payload up; a lighter beam gets a faster one
/// ([`SMC_MODAL_MOVE_RATE_UNLOADED`]).
pub const SMC_MODAL_MOVE_RATE: f64 = 12.0;

/// The moving regulator's degree of stability without a payload, 1/s, falling along a
/// straight line to [`SMC_MODAL_MOVE_RATE`] at [`SMC_MODAL_MOVE_RATE_PAYLOAD_KG`]
/// (`beam_model::lqg::LqgWeights::move_rate_at`; the drive knows its payload, and its
/// designs are made at it).
///
/// With the feedback's low-pass designed in and the observer at 3 N m, the light beams
/// settle sooner under a faster moving regulator and the heavy ones later: at 15 1/s for
/// every payload, over 200 beams of 0-50 g at 90 deg, the slowest beam of those under 12.5
/// g settled in 0.50 s against 0.52 s, of those over 37.5 g in 0.74 s against 0.65 s. At 18
/// 1/s on the unloaded beam, falling to 12 at 25 g, the README's sweep (payloads 0-50 g,
/// whose tail is the heavy beams) keeps its p95 at every length, and over seven sets of 200
/// beams without payloads the p95 falls at 15-180 deg (180 deg 0.58-0.66 s -> 0.54-0.60 s,
/// 90 deg 0.49-0.56 s -> 0.45-0.50 s), none unsettled, at most 1853 ue. At 22 1/s the long
/// moves gained a little more and the 15 deg p95 grew (0.38-0.43 s against 0.34-0.39 s).
/// Chosen on the aluminium beam, like the rate itself: 25 g is a sixth of its mass.
pub const SMC_MODAL_MOVE_RATE_UNLOADED: f64 = 18.0;

/// The payload from which smc-modal's moving regulator runs at [`SMC_MODAL_MOVE_RATE`], kg.
pub const SMC_MODAL_MOVE_RATE_PAYLOAD_KG: f64 = 0.025;

/// The hub angle weight of smc-modal's regulator at rest, as a factor on its rows' `kp`
/// (the moving regulator keeps `kp`): the hold's stiffness.
///
/// The feedback's low-pass, fed back through its own state (`law::FEEDBACK_LOWPASS_HZ`),
/// leaves the hub a static stiffness of `K / (1 + kf)`: 41 N m/rad on the rows' weights,
/// against 101 for the LQR without the filter, and 0.74 deg under 0.5 N m where the hold
/// gave way 0.35 deg before. At twice `kp` at rest the stiffness is 81 N m/rad and the hold
/// 0.42 deg (0.54 deg fed the true state, against 0.97), while the settle times over seven
/// sets of 200 beams, with and without payloads, moved by 0.01 s or less but for two of 42
/// (0.016 and 0.013 s later), and the fourth mode's loop keeps its margin. At 1.5 times:
/// 0.53 deg. The rows' `kp` raised for both regulators (400) held 0.42 deg too, but the
/// 15 deg p95 grew from 0.46 to 0.49 s.
pub const SMC_MODAL_REST_KP_FACTOR: f64 = 2.0;

impl SmcModalGains {
    /// What the law adds to the LQG design: the moving regulator and its rate by payload,
    /// the stiffer regulator at rest, the encoder read as its count's interval at rest, and
    /// the identifier.
    #[cfg(feature = "observer")]
    pub const DESIGN_OPTIONS: DesignOptions = DesignOptions {
        move_rate: SMC_MODAL_MOVE_RATE,
        move_rate_unloaded: SMC_MODAL_MOVE_RATE_UNLOADED,
        move_rate_payload_kg: SMC_MODAL_MOVE_RATE_PAYLOAD_KG,
        rest_kp_factor: SMC_MODAL_REST_KP_FACTOR,
        count_interval: true,
        identify: true,
    };

    /// The LQG weights the surface and the observer are designed from.
    pub const fn design_weights(&self) -> LqgGains {
        LqgGains {
            kp: self.kp,
            kd: SMC_MODAL_KD,
            ki: 0.0,
            kq: self.kq,
            sigma: self.sigma,
        }
    }
}

impl LawGains for SmcModalGains {
    /// The surface from kp 200 and kq 1e4, an observer assuming a 3 N m disturbance, and a
    /// switching term of the paper's shape: A 300 rad/s^2 (2.2 N m at the aluminium beam's
    /// Jeff) with a boundary layer of beta 0.1 s/rad. Chosen by hand with sweeps
    /// (docs/results.md), which found the switching term to matter little either way at
    /// these weights; the shipped rows'. The observer assumed 2 N m until the feedback's
    /// low-pass was designed in ([`super::lqg::FEEDBACK_LOWPASS_HZ`]), which keeps the faster
    /// observer's noise out of the torque: at 3 N m the 45 deg p95 is 0.02-0.035 s shorter
    /// over seven sets of 200 beams, the 15 deg p95 as short or shorter, the 180 deg within
    /// 0.01 s; at 4-6 N m the 90-180 deg p95 grew, at 8 N m beams reached the torque limit.
    const START: Self = SmcModalGains {
        kp: 200.0,
        kq: 10000.0,
        sigma: 3.0,
        a: 300.0,
        beta: 0.1,
        switching: Switching::Tanh,
    };

    /// As the LQG law: its feedforward bends the reference beam through the move.
    const MIN_MOVE_PERIODS: f32 = LqgGains::MIN_MOVE_PERIODS;

    /// 1500 ue: the planner slows a move whose base peak acceleration would bend the
    /// model's beam past it statically (a heavy payload's, and the torque-limited 45 and 90
    /// deg moves at 0 g by 2 %), so that a beam 20 % softer and heavier than the model,
    /// under the faster moving regulator ([`SMC_MODAL_MOVE_RATE`]), stays within 2000 ue
    /// (at most 1834 ue over seven seeds of 200 beams; docs/identification.md).
    const PLANNED_STRAIN: f32 = 1.5e-3;

    /// The LQG design for [`SmcModalGains::design_weights`], refused where the LQG law's is
    /// and when the surface has no hub rate in it (`K_rate <= 0`).
    fn build(
        &self,
        plain: ControlLaw,
        point: &PlantPoint,
        plant: &impl LawPlant,
    ) -> Result<ControlLaw, ParamError> {
        #[cfg(feature = "observer")]
        {
            // The LQG law's refusals, named for this law.
            let _ = point;
            let law = self
                .design_weights()
                .build_with(plain, plant, Self::DESIGN_OPTIONS)
                .map_err(|e| ParamError {
                    field: if e.field == "lqg" {
                        "smc-modal"
                    } else {
                        e.field
                    },
                    ..e
                })?;
            if !(law.observer.k[super::lqg::RATE] > 0.0) {
                return Err(ParamError {
                    field: "kp",
                    kind: ParamErrorKind::NoDesign,
                });
            }
            Ok(law)
        }
        #[cfg(not(feature = "observer"))]
        {
            let _ = (plain, point, plant);
            Err(ParamError {
                field: "smc-modal",
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
        _: f32,
    ) -> f32 {
        #[cfg(feature = "observer")]
        {
            let d = &law.observer;
            let (ff, sigma, _) =
                super::lqg::observe::<{ cfg!(feature = "identify") }, true>(law, x, r, state);
            let s = sigma / d.k[super::lqg::RATE];
            let feedback = sigma + d.jeff * self.a * self.switching.apply(self.beta * s);
            super::lqg::applied(state, ff, feedback, d.torque_limit_nm)
        }
        // Never built without the feature (`build` refuses it).
        #[cfg(not(feature = "observer"))]
        {
            let _ = (law, x, r, state);
            0.0
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::tests::model;
    use super::*;
    use crate::law::Law;

    #[test]
    fn on_a_drives_compiled_plant_it_is_refused_in_its_own_name() {
        // A drive carries the plant at its payload, not a modal model to design on.
        let point = PlantPoint::of(&model());
        let e = ControlLaw::try_build(Law::SmcModal(SmcModalGains::START), point).unwrap_err();
        assert_eq!(e.field, "smc-modal");
        assert_eq!(e.kind, crate::beam::ParamErrorKind::NeedsModel);
    }
}
