//! The wire format against frames written by an independent encoder.

use beam_wire::{decode, DriveMessage, FrameReader, HostMessage, SensorFrame};

/// The fuzz corpus's seed frames were written by an independent Python encoder
/// (`zlib.crc32`, hand-rolled COBS and postcard varints): the Rust decoder must read them,
/// which pins the wire format to its description rather than to itself.
#[test]
fn frames_from_an_independent_encoder_decode() {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/../fuzz/seeds/pil_frame/");
    let read = |name: &str| std::fs::read(format!("{dir}{name}")).unwrap();
    let frames = |bytes: Vec<u8>| {
        let mut r = FrameReader::new();
        bytes
            .into_iter()
            .filter_map(|b| r.push(b).map(|f| f.unwrap().to_vec()))
            .collect::<Vec<_>>()
    };
    let host: Vec<HostMessage> = frames(read("setup_sensors_stop"))
        .into_iter()
        .map(|mut f| decode(&mut f).unwrap())
        .collect();
    assert_eq!(
        host,
        [
            HostMessage::Setup {
                controller: beam_wire::LawKind::Smc,
                payload_kg: 0.0
            },
            HostMessage::Sensors(SensorFrame {
                seq: 0,
                encoder_raw: 0,
                strain_code: 1234,
                amp_fault: false,
                start: false
            }),
            HostMessage::Sensors(SensorFrame {
                seq: 1,
                encoder_raw: 65535,
                strain_code: -8_388_608,
                amp_fault: true,
                start: true
            }),
            HostMessage::Stop,
        ]
    );
    let mut cmd = frames(read("command")).remove(0);
    match decode::<DriveMessage>(&mut cmd).unwrap() {
        DriveMessage::Command(c) => {
            assert_eq!((c.seq, c.torque_nm, c.mode, c.faults), (7, 1.5, 1, 0));
            assert_eq!(c.theta_rad, -1.5707964);
        }
        other => panic!("{other:?}"),
    }
}

/// The command seeds, by the same independent encoder (`fuzz/seeds/make_command_frames.py`).
#[test]
fn command_frames_from_the_independent_encoder_decode() {
    use beam_wire::command::{Command, Request, Waypoint};
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/../fuzz/seeds/command/");
    let requests = |name: &str| -> Vec<Request> {
        let mut r = FrameReader::new();
        std::fs::read(format!("{dir}{name}"))
            .unwrap()
            .into_iter()
            .filter_map(|b| r.push(b).map(|f| f.unwrap().to_vec()))
            .map(|mut f| decode(&mut f).unwrap())
            .collect()
    };
    assert_eq!(
        requests("move_to"),
        [Request {
            seq: 1,
            command: Command::MoveTo {
                to_rad: 0.785,
                time_s: None
            }
        }]
    );
    assert_eq!(
        requests("move_through"),
        [Request {
            seq: 3,
            command: Command::MoveThrough {
                waypoints: [0.17, -0.52]
                    .iter()
                    .map(|&rad| Waypoint { rad, at_s: None })
                    .collect(),
                time_s: None
            }
        }]
    );
    match &requests("move_through_timed")[0].command {
        Command::MoveThrough { waypoints, .. } => {
            assert_eq!(waypoints.len(), 8);
            assert_eq!(waypoints[7].at_s, Some(1.6));
        }
        other => panic!("{other:?}"),
    }
    assert_eq!(
        requests("set_payload")[0].command,
        Command::SetPayload { kg: 0.025 }
    );
    let many: Vec<Command> = requests("stop_disable_clear_status")
        .into_iter()
        .map(|r| r.command)
        .collect();
    assert_eq!(
        many,
        [
            Command::Stop,
            Command::Disable,
            Command::ClearFault,
            Command::Status
        ]
    );
    assert_eq!(requests("stream")[0].command, Command::Stream { every: 10 });
}
