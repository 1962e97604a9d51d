//! The drive's command protocol: what a host asks of a running drive and what it answers,
//! in the same envelope as the PIL frames ([`encode`](crate::encode), [`decode`](crate::decode)).
//!
//! Every [`Request`] carries a sequence number and gets exactly one [`Reply`] with the same
//! number. A frame that does not decode gets a [`Outcome::BadFrame`] reply numbered 0 and
//! changes nothing. Commands that start or change a move ([`Command::MoveTo`],
//! [`Command::MoveThrough`], [`Command::SetPayload`]) are refused with
//! [`Refusal::Busy`] while a move runs: the drive does not queue, so what it does is always
//! the last move it accepted, and a host that wants a sequence sends the next command when
//! `Status` says the move is over. [`Command::Stop`] is accepted mid-move (a planned stop
//! to rest within the limits); [`Command::Disable`] cuts the torque at once.

use crate::LawKind;
use serde::{Deserialize, Serialize};

/// Most waypoints in one [`Command::MoveThrough`].
pub const MAX_WAYPOINTS: usize = 8;

/// A command and its sequence number.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Request {
    /// Chosen by the host, echoed in the reply (0 is kept for replies to bad frames).
    pub seq: u16,
    /// What to do.
    pub command: Command,
}

/// A point a move passes through.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Waypoint {
    /// Hub angle, rad.
    pub rad: f32,
    /// When to be there, s after the move starts (`None`: the drive chooses).
    pub at_s: Option<f32>,
}

/// What a host can ask.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum Command {
    /// Move from where the hub is to `to_rad`, in `time_s` or the shortest time the limits
    /// allow.
    MoveTo {
        /// Target, rad.
        to_rad: f32,
        /// Duration of the base move, s (the shaper adds its length).
        time_s: Option<f32>,
    },
    /// Move through `waypoints` (the last is the target) without stopping between them.
    MoveThrough {
        /// The waypoints, in order.
        waypoints: heapless::Vec<Waypoint, MAX_WAYPOINTS>,
        /// Duration of the base move when the waypoints have no times, s.
        time_s: Option<f32>,
    },
    /// Carry this payload: the gains and shaper are rescheduled from the drive's table.
    SetPayload {
        /// Tip mass, kg.
        kg: f32,
    },
    /// Stop a move: a planned deceleration to rest within the limits, then hold.
    Stop,
    /// Torque off now (and no hold); the next move starts from where the hub is.
    Disable,
    /// Clear latched faults (torque stays off until the next move).
    ClearFault,
    /// Report the drive's state.
    Status,
    /// Telemetry on (one record every `every` ticks) or off (`every` = 0).
    Stream {
        /// Decimation, ticks per record; 0 turns the stream off.
        every: u16,
    },
}

/// The answer to one [`Request`].
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Reply {
    /// The request's `seq` (0 for a frame that did not decode).
    pub seq: u16,
    /// What came of it.
    pub outcome: Outcome,
}

/// What came of a command.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum Outcome {
    /// A move was planned and started (or a stop planned).
    Moving {
        /// Its planned duration, s, shaping included.
        duration_s: f32,
    },
    /// Done (payload set, disabled, faults cleared, stream set).
    Done,
    /// The state, for [`Command::Status`].
    Status(Status),
    /// Not done, and why; nothing changed.
    Refused(Refusal),
    /// The frame did not decode; nothing changed.
    BadFrame(crate::FrameError),
}

/// Why a command was refused.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Refusal {
    /// The move needs more time to keep the torque and speed limits.
    TooFast {
        /// The shortest time that keeps them, s.
        needs_s: f32,
    },
    /// A target, waypoint or the path between them leaves the range.
    OutOfRange {
        /// The offending angle, rad.
        rad: f32,
    },
    /// A move is running: stop it or wait for it to end.
    Busy,
    /// A fault is latched: clear it first.
    Faulted,
    /// Nothing to stop.
    NotMoving,
    /// An argument is unusable (NaN, a negative payload, times not increasing, no
    /// waypoints, mixed given and free times).
    BadArgument,
    /// The gain table has no row for the drive's law.
    NoGains,
    /// The hub still moves (faster than the drive's rest threshold): a move starts from
    /// rest, so wait for the hub to stop.
    HubMoving,
    /// The move would last longer than the drive accepts.
    TooLong {
        /// The longest move, s.
        max_s: f32,
    },
}

/// Everything a commanded drive sends on its link: replies, and telemetry while streaming.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum Uplink {
    /// The answer to a request.
    Reply(Reply),
    /// One tick's telemetry (every `Stream { every }` ticks).
    Record(Record),
}

/// One tick's telemetry on the link: what `beam calibrate` needs, and the link's own
/// health.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Record {
    /// Tick number since power-on.
    pub tick: u32,
    /// Torque commanded, N m.
    pub torque_nm: f32,
    /// Hub angle, rad.
    pub theta_rad: f32,
    /// Reference angle, rad.
    pub theta_ref_rad: f32,
    /// Root strain, offset removed.
    pub strain: f32,
    /// Controller mode: 0 idle, 1 slewing, 2 holding, 3 fault.
    pub mode: u8,
    /// Latched fault bits.
    pub faults: u16,
    /// Records the drive has had to drop so far (the link was full).
    pub dropped: u32,
}

/// The drive's state, as [`Command::Status`] reports it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Status {
    /// Controller mode: 0 idle, 1 slewing, 2 holding, 3 fault.
    pub mode: u8,
    /// Latched fault bits (`model_core::FaultFlags`).
    pub faults: u16,
    /// Hub angle, rad.
    pub theta_rad: f32,
    /// Hub rate (filtered), rad/s.
    pub omega_rad_s: f32,
    /// Root strain (offset removed).
    pub strain: f32,
    /// Time into the current move, s (0 when idle).
    pub move_elapsed_s: f32,
    /// The current move's duration, s.
    pub move_duration_s: f32,
    /// The payload the gains are scheduled for, kg.
    pub payload_kg: f32,
    /// The law in use.
    pub law: Option<LawKind>,
    /// Telemetry decimation (0: off).
    pub stream_every: u16,
    /// Ticks the controller has run since power-up (wraps): two replies apart show the loop
    /// running.
    pub ticks: u32,
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{decode, encode, FrameError, MAX_FRAME};

    fn through(n: usize) -> Command {
        Command::MoveThrough {
            waypoints: (0..n)
                .map(|i| Waypoint {
                    rad: i as f32 * 0.1 - 3.0,
                    at_s: Some(0.25 * (i + 1) as f32),
                })
                .collect(),
            time_s: None,
        }
    }

    #[test]
    fn every_command_and_reply_fits_a_frame_and_survives_the_round_trip() {
        let commands = [
            Command::MoveTo {
                to_rad: 1.0,
                time_s: Some(0.3),
            },
            Command::MoveTo {
                to_rad: -1.0,
                time_s: None,
            },
            through(MAX_WAYPOINTS),
            Command::SetPayload { kg: 0.025 },
            Command::Stop,
            Command::Disable,
            Command::ClearFault,
            Command::Status,
            Command::Stream { every: 10 },
        ];
        for (i, command) in commands.into_iter().enumerate() {
            let req = Request {
                seq: u16::MAX - i as u16,
                command,
            };
            let mut buf = [0u8; MAX_FRAME + 1];
            let mut frame = encode(&req, &mut buf).unwrap().to_vec();
            frame.pop();
            assert_eq!(decode::<Request>(&mut frame), Ok(req));
        }
        let status = Status {
            mode: 2,
            faults: 0x81,
            theta_rad: -3.1,
            omega_rad_s: 1e-3,
            strain: -2e-4,
            move_elapsed_s: 0.35,
            move_duration_s: 0.56,
            payload_kg: 0.05,
            law: Some(LawKind::SmcI),
            stream_every: u16::MAX,
            ticks: u32::MAX,
        };
        for outcome in [
            Outcome::Moving { duration_s: 0.5 },
            Outcome::Done,
            Outcome::Status(status),
            Outcome::Refused(Refusal::TooFast { needs_s: 0.2 }),
            Outcome::Refused(Refusal::OutOfRange { rad: 4.0 }),
            Outcome::BadFrame(FrameError::Crc {
                got: u32::MAX,
                computed: 0,
            }),
        ] {
            let reply = Reply { seq: 7, outcome };
            let mut buf = [0u8; MAX_FRAME + 1];
            let mut frame = encode(&reply, &mut buf).unwrap().to_vec();
            frame.pop();
            assert_eq!(decode::<Reply>(&mut frame), Ok(reply));
        }
    }

    #[test]
    fn more_waypoints_than_a_move_holds_do_not_decode() {
        // Encoded by hand: postcard writes a Vec as its length and the items, so a host
        // with a longer list produces a frame the drive refuses as a payload error.
        let long: heapless::Vec<Waypoint, 16> = (0..MAX_WAYPOINTS + 1)
            .map(|_| Waypoint {
                rad: 0.0,
                at_s: None,
            })
            .collect();
        #[derive(Serialize)]
        #[allow(clippy::large_enum_variant)] // a test's stand-in, built once
        enum Fake {
            _MoveTo,
            MoveThrough(heapless::Vec<Waypoint, 16>, Option<f32>),
        }
        #[derive(Serialize)]
        struct FakeRequest {
            seq: u16,
            command: Fake,
        }
        // Framed as a request would be.
        impl crate::Message for FakeRequest {
            const KIND: u8 = <Request as crate::Message>::KIND;
        }
        let fake = FakeRequest {
            seq: 1,
            command: Fake::MoveThrough(long, None),
        };
        let mut buf = [0u8; MAX_FRAME + 1];
        let mut frame = encode(&fake, &mut buf).unwrap().to_vec();
        frame.pop();
        assert_eq!(decode::<Request>(&mut frame), Err(FrameError::Payload));
    }
}
