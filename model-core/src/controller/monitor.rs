//! The observer laws' sensor monitor: what their observer makes of the encoder and the root
//! gauge each tick, as faults (`gauge`, `encoder-stuck`, and `over-strain` on the estimated
//! strain). docs/faults.md has what it sees.

#[cfg(feature = "observer")]
use super::{ControllerSettings, FaultFlags};
#[cfg(feature = "observer")]
use crate::law::LawState;
#[cfg(feature = "observer")]
use crate::spline::RefPoint;

/// How far the root gauge may read from the observer's prediction (the innovation's
/// magnitude, low-passed over ten ticks) before it is taken as failed, strain (70 ue). The
/// shipped observer laws stayed below 53 ue on beams 20 % off the model in stiffness or
/// density through 15-180 deg moves and a 0.5 N m load, and none of 800 drawn beams trips
/// it with today's faster moves; a gauge read as zero, stuck, reversed, three times too high
/// or 1000 ue off goes past it (or past the trip) within a few ticks of a move
/// (docs/faults.md).
pub const GAUGE_RESIDUAL: f32 = 70e-6;

/// How far the encoder may read from the observer's prediction, low-passed likewise, rad
/// (20 mrad; beams 20 % off the model stay below 13 mrad).
pub const ENCODER_RESIDUAL: f32 = 20e-3;

/// The sensor monitor of the observer laws: what their observer makes of the sensors this
/// tick (zero residuals for the laws without one, which pass). A residual past its bound is
/// blamed on the loop when the torque has swung to a limit from the other side of zero at
/// rest this move (it rang: [`FaultFlags::RINGING`]), on the encoder when the encoder has
/// not counted for 5 ticks while the reference moves (a stuck encoder:
/// [`FaultFlags::ENCODER_STUCK`]), on the gauge otherwise ([`FaultFlags::GAUGE`]); and the
/// beam's strain as the observer estimates it, whatever the gauge says, is held to the trip
/// ([`FaultFlags::OVER_STRAIN`]).
#[cfg(feature = "observer")]
#[inline(always)]
pub(super) fn watch_sensors(
    law: &LawState,
    s: &ControllerSettings,
    still_ticks: u32,
    r: &RefPoint,
) -> FaultFlags {
    let o = &law.lqg;
    let mut faults = FaultFlags::default();
    if o.residual_strain > GAUGE_RESIDUAL || o.residual_theta > ENCODER_RESIDUAL {
        if o.rang {
            faults.insert(FaultFlags::RINGING);
        } else if still_ticks >= 5 && r.vel != 0.0 {
            faults.insert(FaultFlags::ENCODER_STUCK);
        } else {
            faults.insert(FaultFlags::GAUGE);
        }
    }
    if libm::fabsf(o.strain_estimate) > s.max_strain {
        faults.insert(FaultFlags::OVER_STRAIN);
    }
    faults
}
