//! The processor-in-the-loop wire format: the frames the host's plant and the emulated drive
//! exchange once per tick over semihosting stdin/stdout.
//!
//! A frame is a postcard-serialised message inside a checked envelope, COBS-encoded and
//! ended by a zero byte:
//!
//! ```text
//! COBS( VERSION << 4 | KIND:u8 | LEN:u8 | payload: LEN bytes (postcard) | CRC-32/ISO-HDLC of the above: u32 LE ) 0x00
//! ```
//!
//! `KIND` names the message type ([`Message::KIND`]): the PIL protocol's two directions and
//! the command protocol's two share the envelope, and a frame of one is never read as the
//! other (a PIL sensor frame is not a command, an echoed reply not a request). Empty frames
//! (a delimiter after a delimiter) are skipped, so a sender may start with a delimiter to
//! end whatever noise came before.
//!
//! Every way a frame can be wrong has its own [`FrameError`]: too long, bad COBS, too short
//! for its envelope, another protocol version, a length that disagrees with the bytes, a CRC
//! mismatch, a payload that does not deserialise, bytes left over. Sequence numbers (the tick)
//! are checked by both ends on top of this. The same code runs in the PIL firmware and in
//! `beam pil`, so both sides detect the same faults in the same way.
//!
//! Its own crate, `no_std` and free of the controller, because both ends depend on it: the
//! firmware (the PIL drive) and the host (`beam pil`), and the drive's command protocol is to
//! travel in the same envelope.
#![cfg_attr(not(test), no_std)]
#![forbid(unsafe_code)]

pub mod command;

pub use beam_kinds::LawKind;
use serde::{Deserialize, Serialize};

/// Protocol version (the header byte's high four bits); bumped whenever a message changes.
pub const VERSION: u8 = 2;

/// A message the envelope carries, with the kind its header names (1 to 15).
pub trait Message {
    /// The header's low four bits for this message type.
    const KIND: u8;
}

impl Message for HostMessage {
    const KIND: u8 = 1;
}

impl Message for DriveMessage {
    const KIND: u8 = 2;
}

impl Message for command::Request {
    const KIND: u8 = 3;
}

impl Message for command::Uplink {
    const KIND: u8 = 4;
}

impl Message for command::Reply {
    const KIND: u8 = 5;
}
/// Largest payload, bytes.
pub const MAX_PAYLOAD: usize = 96;
/// Largest frame before COBS: version, length, payload, CRC.
pub const MAX_RAW: usize = 2 + MAX_PAYLOAD + 4;
/// Largest encoded frame, excluding the zero delimiter.
pub const MAX_FRAME: usize = cobs::max_encoding_length(MAX_RAW);

/// CRC-32 (ISO-HDLC, as Ethernet and zlib), computed bit by bit: a frame is at most about a
/// hundred bytes and is checked outside the 1 kHz tick, while the byte-wise table would take 1 KiB
/// of the board's flash.
const CRC: crc::Crc<u32, crc::NoTable> = crc::Crc::<u32, crc::NoTable>::new(&crc::CRC_32_ISO_HDLC);

/// One tick's sensor readings, as the board's drivers would have produced them.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct SensorFrame {
    /// Tick number, from 0, one more each frame.
    pub seq: u32,
    /// The encoder counter (only its low 16 bits on this board).
    pub encoder_raw: u32,
    /// The bridge converter's 24-bit code.
    pub strain_code: i32,
    /// The amplifier's fault line is asserted.
    pub amp_fault: bool,
    /// START is pressed this tick (runs the move beginning nearest the hub).
    pub start: bool,
}

/// What the drive did with one [`SensorFrame`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct CommandFrame {
    /// The sensor frame's `seq`.
    pub seq: u32,
    /// Torque commanded, N m.
    pub torque_nm: f32,
    /// Hub angle the controller measured, rad.
    pub theta_rad: f32,
    /// Root strain the controller measured (offset removed).
    pub strain: f32,
    /// Controller mode: 0 idle, 1 slewing, 2 holding, 3 fault.
    pub mode: u8,
    /// Latched fault bits (`model_core::FaultFlags`).
    pub faults: u16,
}

/// Host to drive. Variants are only ever appended, so a frame of an older host still
/// decodes the same (the version is bumped when an existing message changes).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum HostMessage {
    /// Build the controller: which law, for which payload. First message of a run.
    Setup {
        /// The law.
        controller: LawKind,
        /// Payload, kg (schedules the gains and sets the model's tip mass).
        payload_kg: f32,
    },
    /// One tick.
    Sensors(SensorFrame),
    /// End of the run: the drive exits with status 0.
    Stop,
    /// Build a commanded drive instead (first message of a run): moves come only as
    /// [`HostMessage::Command`]s, planned by the drive from where the hub rests.
    SetupCommanded {
        /// The law.
        controller: LawKind,
        /// Payload, kg (the drive's initial setting).
        payload_kg: f32,
        /// Where the hub rests at power-up, rad (the encoder's zero).
        home_rad: f32,
    },
    /// A command for a commanded drive, carried out before the next tick and answered
    /// with [`DriveMessage::Reply`].
    Command(command::Request),
}

/// Drive to host.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum DriveMessage {
    /// The controller is built and idle.
    Ready,
    /// One tick's command.
    Command(CommandFrame),
    /// The drive could not go on; it exits after sending this.
    Error(DriveError),
    /// The answer to a [`HostMessage::Command`].
    Reply(command::Reply),
}

/// Why the PIL drive stopped.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum DriveError {
    /// A frame from the host was malformed.
    Frame(FrameError),
    /// A sensor frame arrived out of order.
    Sequence {
        /// The tick expected.
        expected: u32,
        /// The tick received.
        got: u32,
    },
    /// A message came that is not valid at this point (sensors before setup, setup twice).
    Unexpected,
    /// The compiled-in configuration failed to build for the requested setup.
    Config,
    /// Stdin ended in the middle of a run.
    EndOfInput,
    /// Semihosting I/O failed.
    Io,
}

/// A malformed frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum FrameError {
    /// More bytes than any valid frame before the delimiter.
    TooLong,
    /// The COBS encoding is broken.
    Cobs,
    /// Fewer bytes than the envelope needs.
    Short {
        /// Bytes after COBS decoding.
        len: u16,
    },
    /// Another protocol version.
    Version {
        /// The version in the frame.
        got: u8,
    },
    /// The length byte disagrees with the frame.
    Length {
        /// The length byte.
        declared: u8,
        /// Payload bytes present.
        actual: u16,
    },
    /// The CRC does not match.
    Crc {
        /// CRC in the frame.
        got: u32,
        /// CRC of the bytes.
        computed: u32,
    },
    /// The payload does not deserialise as the expected message.
    Payload,
    /// The message left payload bytes unread.
    TrailingBytes,
    /// The message does not fit a frame (a bug on the sending side).
    Encode,
    /// A frame of another message type (the other protocol, or the other direction).
    Kind {
        /// The kind in the frame (the receiver knows the one it expects).
        got: u8,
    },
}

impl core::fmt::Display for FrameError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            FrameError::TooLong => write!(f, "frame longer than {MAX_FRAME} bytes"),
            FrameError::Cobs => write!(f, "broken COBS encoding"),
            FrameError::Short { len } => write!(f, "short frame ({len} bytes)"),
            FrameError::Version { got } => {
                write!(f, "protocol version {got}, expected {VERSION}")
            }
            FrameError::Length { declared, actual } => {
                write!(f, "length byte says {declared}, frame has {actual}")
            }
            FrameError::Crc { got, computed } => {
                write!(f, "CRC {got:#010x}, computed {computed:#010x}")
            }
            FrameError::Payload => write!(f, "payload does not decode"),
            FrameError::TrailingBytes => write!(f, "payload has trailing bytes"),
            FrameError::Encode => write!(f, "message too large for a frame"),
            FrameError::Kind { got } => write!(f, "a frame of another message kind ({got})"),
        }
    }
}

impl core::error::Error for FrameError {}

impl core::fmt::Display for DriveError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            DriveError::Frame(e) => write!(f, "bad frame from the host: {e}"),
            DriveError::Sequence { expected, got } => {
                write!(f, "sensor frame {got} out of order, expected {expected}")
            }
            DriveError::Unexpected => write!(f, "unexpected message"),
            DriveError::Config => write!(f, "the controller could not be built"),
            DriveError::EndOfInput => write!(f, "input ended mid-run"),
            DriveError::Io => write!(f, "semihosting I/O error"),
        }
    }
}

impl core::error::Error for DriveError {}

/// Collects bytes into frames: everything up to a zero delimiter.
#[derive(Debug)]
pub struct FrameReader {
    buf: [u8; MAX_FRAME],
    len: usize,
    overflow: bool,
}

impl Default for FrameReader {
    fn default() -> Self {
        Self::new()
    }
}

impl FrameReader {
    /// An empty reader.
    pub const fn new() -> Self {
        Self {
            buf: [0; MAX_FRAME],
            len: 0,
            overflow: false,
        }
    }

    /// Takes one byte. At a delimiter ending a frame that has bytes, returns them (ready
    /// for [`decode`]) or [`FrameError::TooLong`] if more bytes came than a frame can hold;
    /// the reader is then empty again, so one bad frame does not swallow the next. An empty
    /// frame (a delimiter right after another, or first) returns nothing.
    pub fn push(&mut self, byte: u8) -> Option<Result<&mut [u8], FrameError>> {
        if byte != 0 {
            if self.len < self.buf.len() {
                self.buf[self.len] = byte;
                self.len += 1;
            } else {
                self.overflow = true;
            }
            return None;
        }
        let (len, overflow) = (self.len, self.overflow);
        if len == 0 && !overflow {
            // An empty frame: a delimiter after a delimiter (a sender's leading one).
            return None;
        }
        self.len = 0;
        self.overflow = false;
        Some(if overflow {
            Err(FrameError::TooLong)
        } else {
            // `len` never passes the buffer; `get` keeps the panic path out all the same.
            self.buf.get_mut(..len).ok_or(FrameError::TooLong)
        })
    }

    /// True when a frame has started but not ended (input that stops here was cut short).
    pub fn partial(&self) -> bool {
        self.len > 0 || self.overflow
    }
}

/// Encodes `msg` into `out` and returns the frame including its zero delimiter. (Slices are
/// taken with `get`, so no path here can panic: the drive runs it in an interrupt.)
pub fn encode<'a, T: Serialize + Message>(
    msg: &T,
    out: &'a mut [u8; MAX_FRAME + 1],
) -> Result<&'a [u8], FrameError> {
    let mut raw = [0u8; MAX_RAW];
    let n = postcard::to_slice(msg, &mut raw[2..2 + MAX_PAYLOAD])
        .map_err(|_| FrameError::Encode)?
        .len();
    raw[0] = VERSION << 4 | T::KIND;
    raw[1] = u8::try_from(n).map_err(|_| FrameError::Encode)?;
    let crc = CRC.checksum(raw.get(..2 + n).ok_or(FrameError::Encode)?);
    raw.get_mut(2 + n..6 + n)
        .ok_or(FrameError::Encode)?
        .copy_from_slice(&crc.to_le_bytes());
    let len = cobs::try_encode(
        raw.get(..6 + n).ok_or(FrameError::Encode)?,
        &mut out[..MAX_FRAME],
    )
    .map_err(|_| FrameError::Encode)?;
    *out.get_mut(len).ok_or(FrameError::Encode)? = 0;
    out.get(..=len).ok_or(FrameError::Encode)
}

/// COBS-decodes `buf` in place (the bytes before the frame's zero delimiter) and returns
/// the decoded length, or `None` for bytes that are not COBS (a zero inside, or a code that
/// runs past the end). The `cobs` crate's decoder does the same but indexes with bounds
/// checks, which put a panic (and `core::fmt`) on the drive's receive interrupt; this one
/// reads and writes only through `get`.
pub fn cobs_decode_in_place(buf: &mut [u8]) -> Option<usize> {
    // Nothing is not a COBS encoding (of nothing, it is one code byte).
    if buf.is_empty() {
        return None;
    }
    let (mut read, mut write) = (0usize, 0usize);
    while let Some(&code) = buf.get(read) {
        if code == 0 {
            return None;
        }
        read += 1;
        for _ in 1..code {
            let byte = *buf.get(read)?;
            if byte == 0 {
                return None;
            }
            *buf.get_mut(write)? = byte;
            read += 1;
            write += 1;
        }
        // A code below 0xFF ends a group with a zero, unless the data ends there.
        if code != 0xFF && read < buf.len() {
            *buf.get_mut(write)? = 0;
            write += 1;
        }
    }
    Some(write)
}

/// Decodes one frame (the bytes before its zero delimiter, decoded in place) as a `T`.
pub fn decode<'de, T: Deserialize<'de> + Message>(frame: &'de mut [u8]) -> Result<T, FrameError> {
    if frame.len() > MAX_FRAME {
        return Err(FrameError::TooLong);
    }
    let n = cobs_decode_in_place(frame).ok_or(FrameError::Cobs)?;
    let raw: &[u8] = frame.get(..n).ok_or(FrameError::Cobs)?;
    let (Some(&version), Some(&declared)) = (raw.first(), raw.get(1)) else {
        return Err(FrameError::Short { len: n as u16 });
    };
    if n < 6 {
        return Err(FrameError::Short { len: n as u16 });
    }
    if version >> 4 != VERSION {
        return Err(FrameError::Version { got: version >> 4 });
    }
    if version & 0x0F != T::KIND {
        return Err(FrameError::Kind {
            got: version & 0x0F,
        });
    }
    let actual = n - 6;
    if declared as usize != actual {
        return Err(FrameError::Length {
            declared,
            actual: actual as u16,
        });
    }
    let (body, crc) = raw
        .split_at_checked(n - 4)
        .ok_or(FrameError::Short { len: n as u16 })?;
    let crc: [u8; 4] = crc
        .try_into()
        .map_err(|_| FrameError::Short { len: n as u16 })?;
    let got = u32::from_le_bytes(crc);
    let computed = CRC.checksum(body);
    if got != computed {
        return Err(FrameError::Crc { got, computed });
    }
    let payload = body.get(2..).ok_or(FrameError::Short { len: n as u16 })?;
    let (msg, rest) = postcard::take_from_bytes(payload).map_err(|_| FrameError::Payload)?;
    if !rest.is_empty() {
        return Err(FrameError::TrailingBytes);
    }
    Ok(msg)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn roundtrip(m: HostMessage) -> Result<HostMessage, FrameError> {
        let mut buf = [0u8; MAX_FRAME + 1];
        let frame = encode(&m, &mut buf)?.to_vec();
        assert_eq!(frame.last(), Some(&0));
        assert!(!frame[..frame.len() - 1].contains(&0));
        let mut body = frame[..frame.len() - 1].to_vec();
        decode(&mut body)
    }

    fn sensors() -> HostMessage {
        HostMessage::Sensors(SensorFrame {
            seq: 123_456,
            encoder_raw: 65_535,
            strain_code: -8_388_608,
            amp_fault: true,
            start: false,
        })
    }

    #[test]
    fn every_message_survives_the_round_trip() {
        for m in [
            sensors(),
            HostMessage::Stop,
            HostMessage::Setup {
                controller: LawKind::SmcStrain,
                payload_kg: 0.025,
            },
        ] {
            assert_eq!(roundtrip(m.clone()), Ok(m));
        }
        let mut buf = [0u8; MAX_FRAME + 1];
        let c = DriveMessage::Command(CommandFrame {
            seq: u32::MAX,
            torque_nm: -f32::MAX,
            theta_rad: f32::NAN,
            strain: 1e-6,
            mode: 3,
            faults: 0x7F,
        });
        let frame = encode(&c, &mut buf).unwrap().to_vec();
        let mut body = frame[..frame.len() - 1].to_vec();
        let back: DriveMessage = decode(&mut body).unwrap();
        // NaN != NaN, so compare the bits.
        match back {
            DriveMessage::Command(b) => assert_eq!(b.theta_rad.to_bits(), f32::NAN.to_bits()),
            other => panic!("{other:?}"),
        }
    }

    fn encoded(m: HostMessage) -> Vec<u8> {
        let mut buf = [0u8; MAX_FRAME + 1];
        let f = encode(&m, &mut buf).unwrap();
        f[..f.len() - 1].to_vec()
    }

    /// COBS-encodes raw envelope bytes as a sender would, without checking them.
    fn wrap(raw: &[u8]) -> Vec<u8> {
        let mut out = vec![0u8; cobs::max_encoding_length(raw.len())];
        let n = cobs::try_encode(raw, &mut out).unwrap();
        out.truncate(n);
        out
    }

    proptest::proptest! {
        /// The drive's decoder agrees with the `cobs` crate's on any bytes: the same
        /// verdict, and the same bytes when both decode (the crate's is the reference).
        #[test]
        fn the_panic_free_cobs_decoder_agrees_with_the_crate(
            raw in proptest::collection::vec(proptest::num::u8::ANY, 0..300),
            garbage in proptest::collection::vec(1u8..=255, 0..300),
        ) {
            // Encoded data round-trips.
            let mut framed = wrap(&raw);
            let n = cobs_decode_in_place(&mut framed);
            proptest::prop_assert_eq!(n, Some(raw.len()));
            proptest::prop_assert_eq!(&framed[..raw.len()], &raw[..]);
            // Any zero-free bytes: the same verdict as the crate.
            let (mut ours, mut theirs) = (garbage.clone(), garbage.clone());
            let a = cobs_decode_in_place(&mut ours);
            let b = cobs::decode_in_place(&mut theirs).ok();
            proptest::prop_assert_eq!(a, b);
            if let Some(n) = a {
                proptest::prop_assert_eq!(&ours[..n], &theirs[..n]);
            }
        }
    }

    fn raw_of(m: HostMessage) -> Vec<u8> {
        let mut f = encoded(m);
        let n = cobs::decode_in_place(&mut f).unwrap();
        f.truncate(n);
        f
    }

    #[test]
    fn the_reader_splits_frames_and_recovers_after_an_overlong_one() {
        let mut bytes = encoded(sensors());
        bytes.push(0);
        bytes.extend(vec![7u8; MAX_FRAME + 5]);
        bytes.push(0);
        bytes.extend(encoded(HostMessage::Stop));
        bytes.push(0);
        bytes.extend([1, 2]);
        let mut r = FrameReader::new();
        let mut got = vec![];
        for b in bytes {
            if let Some(frame) = r.push(b) {
                got.push(frame.and_then(decode::<HostMessage>));
            }
        }
        assert_eq!(
            got,
            [
                Ok(sensors()),
                Err(FrameError::TooLong),
                Ok(HostMessage::Stop)
            ]
        );
        assert!(r.partial());
        // Empty frames (delimiters in a row, or a sender's leading one) are skipped.
        let mut bytes = vec![0, 0];
        bytes.extend(encoded(HostMessage::Stop));
        bytes.extend([0, 0, 0]);
        let mut r = FrameReader::new();
        let got: Vec<_> = bytes
            .into_iter()
            .filter_map(|b| r.push(b).map(|f| f.and_then(decode::<HostMessage>)))
            .collect();
        assert_eq!(got, [Ok(HostMessage::Stop)]);
    }

    #[test]
    fn each_corruption_is_named() {
        let decode_host = |mut b: Vec<u8>| decode::<HostMessage>(&mut b);
        // Every single-bit flip of a valid frame is caught (by COBS, the envelope or the CRC).
        let good = encoded(sensors());
        for i in 0..good.len() * 8 {
            let mut bad = good.clone();
            bad[i / 8] ^= 1 << (i % 8);
            if bad[i / 8] == 0 {
                continue; // a zero would end the frame early: the short case below
            }
            assert!(decode_host(bad).is_err(), "bit {i} flipped went unnoticed");
        }
        assert_eq!(
            decode_host(vec![1; MAX_FRAME + 1]),
            Err(FrameError::TooLong)
        );
        assert_eq!(
            decode_host(wrap(&[1, 0, 0])),
            Err(FrameError::Short { len: 3 })
        );
        // A truncated frame (a delimiter lost in the middle) fails its length or CRC.
        let mut raw = raw_of(sensors());
        raw.truncate(raw.len() - 2);
        assert!(matches!(
            decode_host(wrap(&raw)),
            Err(FrameError::Length { .. })
        ));
        let mut raw = raw_of(sensors());
        raw[0] = 9 << 4 | <HostMessage as Message>::KIND;
        assert_eq!(decode_host(wrap(&raw)), Err(FrameError::Version { got: 9 }));
        // A frame of the other protocol, or of the other direction, is never read as this
        // one: a command request is not a PIL message, a drive's reply not a request.
        let request = command::Request {
            seq: 1,
            command: command::Command::SetPayload { kg: 0.0 },
        };
        let mut buf = [0u8; MAX_FRAME + 1];
        let mut f = encode(&request, &mut buf).unwrap().to_vec();
        f.pop();
        assert_eq!(
            decode::<HostMessage>(&mut f.clone()),
            Err(FrameError::Kind { got: 3 })
        );
        let reply = command::Uplink::Reply(command::Reply {
            seq: 1,
            outcome: command::Outcome::Done,
        });
        let mut f = encode(&reply, &mut buf).unwrap().to_vec();
        f.pop();
        assert_eq!(
            decode::<command::Request>(&mut f),
            Err(FrameError::Kind { got: 4 })
        );
        let mut raw = raw_of(sensors());
        let last = raw.len() - 1;
        raw[last] ^= 0x80;
        assert!(matches!(
            decode_host(wrap(&raw)),
            Err(FrameError::Crc { .. })
        ));
        // A well-enveloped payload that is not a host message.
        let head = VERSION << 4 | <HostMessage as Message>::KIND;
        let mut raw = vec![head, 1, 0x07];
        let crc = CRC.checksum(&raw);
        raw.extend(crc.to_le_bytes());
        assert_eq!(decode_host(wrap(&raw)), Err(FrameError::Payload));
        // Stop with a byte after it.
        let mut raw = vec![head, 2, 2, 0x55];
        let crc = CRC.checksum(&raw);
        raw.extend(crc.to_le_bytes());
        assert_eq!(decode_host(wrap(&raw)), Err(FrameError::TrailingBytes));
    }

    #[test]
    fn the_frame_check_is_the_standard_crc_32() {
        // The catalogue's check value of CRC-32/ISO-HDLC, and zlib's CRC of a sentence
        // (`python3 -c 'import zlib; print(hex(zlib.crc32(b"..."))'`): a host in any language
        // checks frames with its own CRC-32.
        assert_eq!(CRC.checksum(b"123456789"), 0xcbf4_3926);
        assert_eq!(
            CRC.checksum(b"The quick brown fox jumps over the lazy dog"),
            0x414f_a339
        );
    }
}
