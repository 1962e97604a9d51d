//! The drive's own law, beside the table's: the brake, the observer laws' fallback on a
//! failed gauge and the hold it takes over from the laws that hold weakly.

use crate::law::{ControlLaw, Estimate};
use crate::spline::RefPoint;

/// The drive's own law: the brake ([`Controller::start_brake`](super::Controller::start_brake)),
/// the fallback of the observer laws on a failed gauge ([`GAUGE_FAULTS`](super::GAUGE_FAULTS)) and the hold of
/// the sliding-mode laws that hold weakly ([`HOLD_HANDOVER_RAD`]):
/// `tau = J theta_r'' + Kp (theta_r - theta) + Kd (theta_r' - theta')` on the hub alone, with `J`
/// the rigid inertia (hub, beam, payload) of the law in use and the PD placed at
/// [`Brake::BANDWIDTH_RAD_S`] with damping [`Brake::DAMPING`] on it. A PD on the hub's own angle
/// and rate, where the torque acts, is stable with any flexible beam on the hub (the collocated
/// loop is passive), and it needs no state that a hub turning fast could leave behind.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Brake {
    /// Rigid inertia, kg m^2.
    pub inertia: f32,
    /// Proportional gain, N m/rad.
    pub kp: f32,
    /// Derivative gain, N m s/rad.
    pub kd: f32,
    /// The drive takes the hold over from the law at the target ([`HOLD_HANDOVER_RAD`]).
    pub takes_hold: bool,
    /// The law cannot run without the gauge (its observer reads it): on a gauge fault the
    /// drive's own law takes the move and the hold over. The other laws run on, on a strain
    /// of zero. Set for exactly the laws with an observer, and so what the tick reads to give
    /// them the acceleration held over the tick (`crate::spline::held_acceleration`).
    pub takes_gauge_loss: bool,
}

/// How close to a held target the hub must be (and slower than [`REST_RAD_S`](super::REST_RAD_S))
/// before the drive's own law ([`Brake`]) takes the hold over from a law that holds weakly, rad
/// (0.05 deg, the settle band). The paper's SMC and the strain SMC push back with at most `Jeff A`
/// at rest, about 0.3 N m with the shipped rows: under 0.5 N m they crept 17-19 deg. Rows designed
/// with the hold test instead (`beam optimize --load-hold 0.5`) either threw the beam out of the
/// model on a quarter of the drawn beams or rang at 240 ue after the move. Handing over at the
/// target leaves the law's move and settling as they were and holds 0.5 N m within 0.8 deg
/// (docs/results.md).
pub const HOLD_HANDOVER_RAD: f32 = 0.05 * core::f32::consts::PI / 180.0;

impl Brake {
    /// The PD's natural frequency on the rigid inertia, rad/s (6.4 Hz): on the aluminium beam
    /// (0.027 kg m^2) Kp 43 N m/rad and Kd 1.5 N m s/rad, the neighbourhood of the
    /// feedforward-plus-PD rows that recover a coasting hub.
    pub const BANDWIDTH_RAD_S: f32 = 40.0;
    /// The PD's damping ratio on the rigid inertia.
    pub const DAMPING: f32 = 0.7;

    /// The drive's own law beside `law`: on its rigid inertia, and taking the hold over from the
    /// sliding-mode laws without integral action or an observer (smc, smc-strain). Not from the PD
    /// baseline: it stays the paper's Kp 20 N m/rad spring, the reference the others are compared
    /// with and the law calibration logs are taken under.
    #[inline(always)] // once per law change; outlined it cost the board 140 B
    pub fn for_law(law: &ControlLaw) -> Self {
        use crate::law::LawKind;
        let kind = law.law().kind();
        Self {
            takes_hold: matches!(kind, LawKind::Smc | LawKind::SmcStrain),
            takes_gauge_loss: kind.has_observer(),
            ..Self::for_inertia(law.rigid_inertia())
        }
    }

    /// The brake for a hub of rigid inertia `inertia` (kg m^2; not positive or not finite gives a
    /// brake of no torque, which the laws' validation rules out); it takes no hold.
    pub fn for_inertia(inertia: f32) -> Self {
        let j = if inertia.is_finite() && inertia > 0.0 {
            inertia
        } else {
            0.0
        };
        Self {
            inertia: j,
            kp: j * Self::BANDWIDTH_RAD_S * Self::BANDWIDTH_RAD_S,
            kd: 2.0 * Self::DAMPING * j * Self::BANDWIDTH_RAD_S,
            takes_hold: false,
            takes_gauge_loss: false,
        }
    }

    /// The brake's torque at `r` for the hub `x`, N m (before the drive's limit).
    #[inline(always)]
    pub(super) fn torque_nm(&self, x: &Estimate, r: &RefPoint) -> f32 {
        self.inertia * r.acc + self.kp * (r.pos - x.theta) + self.kd * (r.vel - x.omega)
    }
}
