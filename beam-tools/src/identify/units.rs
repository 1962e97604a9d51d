//! Unit and sign mistakes in a log, recognised for what they are before any fit: a time
//! column in the wrong unit, an angle in degrees read as radians, a torque in the wrong
//! unit or with the other sign, a strain in microstrain read as strain. Each would otherwise
//! surface, much later, as a fit that fails for another reason.

use crate::identify::calibrate::Log;
use crate::identify::hub::HubMotion;
use beam_log::BeamSensor;
use model_core::{Beam, BeamParams, ModalModel};
use std::fmt;

/// A mistake in a log's units or signs, with the column mapping that fixes it.
#[derive(Clone, Debug, PartialEq)]
pub enum UnitMistake {
    /// Samples far closer or farther apart than any drive logs them.
    SamplePeriod {
        /// The period as read, s.
        dt_s: f64,
    },
    /// A beam signal no metal beam gives.
    BeamSignal {
        /// What the signal is.
        sensor: BeamSensor,
        /// Its size as read (the 99th percentile of its magnitude), SI.
        size: f64,
        /// The beam's length, m.
        length_m: f64,
    },
    /// The torque that would accelerate the rigid body as the logged angle does is far from
    /// the logged torque: the angle or the torque is in the wrong unit.
    TorqueAngleScale {
        /// Rigid inertia times the hub's acceleration, over the logged torque (the 99th
        /// percentiles of their magnitudes).
        ratio: f64,
    },
    /// The logged torque falls as the hub's acceleration rises.
    TorqueSign {
        /// The correlation coefficient of the torque with the acceleration.
        correlation: f64,
    },
}

impl fmt::Display for UnitMistake {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            UnitMistake::SamplePeriod { dt_s } if dt_s < SAMPLE_PERIOD_S.0 => write!(
                f,
                "the samples are {dt_s:.3e} s apart: a time in s read as ms or us? map it \
                 with its unit (`--columns t=COLUMN:s`)"
            ),
            UnitMistake::SamplePeriod { dt_s } => write!(
                f,
                "the samples are {dt_s:.3} s apart: a time in ms or us read as s? map it with \
                 its unit (`--columns t=COLUMN:ms`)"
            ),
            UnitMistake::BeamSignal {
                sensor: BeamSensor::RootStrain,
                size,
                ..
            } => write!(
                f,
                "the strain reads {size:.3e} (a metal beam yields near 0.004): microstrain \
                 read as strain? map it `--columns strain=COLUMN:ue`"
            ),
            UnitMistake::BeamSignal { size, length_m, .. } => write!(
                f,
                "the tip deflection reads {size:.3} m on a {length_m:.3} m beam: millimetres \
                 read as metres? map it `--columns tip=COLUMN:mm`"
            ),
            UnitMistake::TorqueAngleScale { ratio } => {
                let guess = if (19.0..170.0).contains(&ratio) {
                    "the angle in degrees read as radians (`theta=COLUMN:deg`)?"
                } else if (300.0..3000.0).contains(&ratio) {
                    "the torque in N m read as mN m (`torque=COLUMN:nm`)?"
                } else if (1.0 / 170.0..1.0 / 19.0).contains(&ratio) {
                    "the angle in radians read as degrees (`theta=COLUMN:rad`)?"
                } else if (1.0 / 3000.0..1.0 / 300.0).contains(&ratio) {
                    "the torque in mN m read as N m (`torque=COLUMN:mnm`)?"
                } else {
                    "check both columns' units."
                };
                write!(
                    f,
                    "accelerating the hub as logged takes {ratio:.3e} times the logged torque \
                     (with the starting parameters' inertia): {guess}"
                )
            }
            UnitMistake::TorqueSign { correlation } => write!(
                f,
                "the torque falls as the hub's acceleration rises (correlation \
                 {correlation:.2}): the torque or the angle reads with the other sign; flip \
                 one with a leading - on its unit (`torque=COLUMN:-nm`)"
            ),
        }
    }
}

/// Sample periods a drive's log has, s (100 kHz to 20 Hz).
pub const SAMPLE_PERIOD_S: (f64, f64) = (1e-5, 0.05);

/// How far the torque the rigid body needs may be from the logged torque before the units
/// are taken as wrong: a factor of 15 either way. A starting inertia a few times off, a
/// flexible beam's reaction and friction stay within it; a unit read wrong (57 for degrees,
/// 1000 for milli) does not.
pub const TORQUE_ANGLE_FACTOR: f64 = 15.0;

/// The first unit or sign mistake found in `log`, read with the starting parameters
/// `params` (their rigid inertia and length), or `None`.
pub fn unit_mistake(log: &Log, params: &BeamParams) -> Option<UnitMistake> {
    let n = log.t.len();
    if n < 8 {
        return None;
    }
    let dt_s = (log.t[n - 1] - log.t[0]) / (n - 1) as f64;
    if !(SAMPLE_PERIOD_S.0..=SAMPLE_PERIOD_S.1).contains(&dt_s) {
        return Some(UnitMistake::SamplePeriod { dt_s });
    }
    let size = p99(log.beam_signal.iter().map(|v| v.abs()));
    let implausible = match log.sensor {
        BeamSensor::RootStrain => size > 0.02,
        BeamSensor::TipDeflection => size > params.length_m,
    };
    if implausible {
        return Some(UnitMistake::BeamSignal {
            sensor: log.sensor,
            size,
            length_m: params.length_m,
        });
    }
    let inertia = ModalModel::<1>::try_build(&Beam::try_build(*params).ok()?)
        .ok()?
        .mtt;
    let hub = HubMotion::of(log, 0.02);
    let need = p99(hub.alpha.iter().map(|a| (inertia * a).abs()));
    let logged = p99(log.torque.iter().map(|u| u.abs()));
    if !(need > 0.0 && logged > 0.0) {
        return None;
    }
    let ratio = need / logged;
    if !(1.0 / TORQUE_ANGLE_FACTOR..=TORQUE_ANGLE_FACTOR).contains(&ratio) {
        return Some(UnitMistake::TorqueAngleScale { ratio });
    }
    // The torque drives the hub's acceleration: they rise and fall together while the hub
    // moves (at rest the acceleration is the encoder's noise, and friction holds the hub
    // against whatever torque).
    let fastest = hub.omega.iter().fold(0.0f64, |m, w| m.max(w.abs()));
    let moving: Vec<usize> = (0..n)
        .filter(|&k| hub.omega[k].abs() > 0.1 * fastest)
        .collect();
    let pick = |v: &[f64]| moving.iter().map(|&k| v[k]).collect::<Vec<f64>>();
    let correlation = correlation(&pick(&log.torque), &pick(&hub.alpha));
    if correlation < -0.2 {
        return Some(UnitMistake::TorqueSign { correlation });
    }
    None
}

/// The correlation coefficient of `a` and `b` (0 where either is constant).
fn correlation(a: &[f64], b: &[f64]) -> f64 {
    let n = a.len().min(b.len()) as f64;
    let (ma, mb) = (a.iter().sum::<f64>() / n, b.iter().sum::<f64>() / n);
    let (mut ab, mut aa, mut bb) = (0.0, 0.0, 0.0);
    for (x, y) in a.iter().zip(b) {
        ab += (x - ma) * (y - mb);
        aa += (x - ma) * (x - ma);
        bb += (y - mb) * (y - mb);
    }
    let r = ab / (aa * bb).sqrt();
    if r.is_finite() {
        r
    } else {
        0.0
    }
}

/// The 99th percentile of `values` (0 for none).
fn p99(values: impl Iterator<Item = f64>) -> f64 {
    let mut v: Vec<f64> = values.filter(|x| x.is_finite()).collect();
    if v.is_empty() {
        return 0.0;
    }
    v.sort_by(f64::total_cmp);
    v[((v.len() - 1) as f64 * 0.99).round() as usize]
}
