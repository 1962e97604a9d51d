//! The drive's serial link, independent of the transport: command frames in, replies and
//! telemetry out, framed as `beam-wire` frames (docs/design.md, section 10).
//!
//! Interrupt-driven and never blocking: the receive interrupt hands each byte to
//! [`Link::receive_byte`], which assembles frames and queues decoded requests (a frame that
//! does not decode gets a `BadFrame` reply at once); the link task takes requests with
//! [`Link::next_request`] and queues replies and telemetry, encoded, into a transmit ring
//! that the transmit interrupt drains with [`Link::next_tx_byte`]. The tick never touches
//! the link. Telemetry is shed first: a record is queued only if the ring keeps room for a
//! reply after it, so a reply is never lost to a telemetry stream, and every record that did
//! not fit is counted (and the count travels in the next record that does).
//!
//! At 921 600 baud (92 160 bytes/s) a record frame of at most [`RECORD_FRAME_MAX`] bytes every
//! tick uses under half of the line, so a 1 kHz stream drops nothing (measured in the tests
//! against a model of the line).

use beam_wire::command::{Outcome, Record, Reply, Request, Uplink};
use beam_wire::{decode, encode, FrameReader, MAX_FRAME};
use heapless::Deque;

/// The link's baud rate on the board.
pub const BAUD: u32 = 921_600;

/// The longest encoded record frame, delimiter included, bytes (postcard varints at their
/// widest, COBS overhead, the envelope).
pub const RECORD_FRAME_MAX: usize = 48;

/// Requests waiting for the link task; a request arriving when this many wait is answered
/// `Busy` at once.
pub const REQUEST_SLOTS: usize = 4;

/// What the link has counted.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct LinkStats {
    /// Frames that did not decode.
    pub bad_frames: u32,
    /// Requests answered `Busy` because the queue was full.
    pub requests_refused: u32,
    /// Telemetry records dropped because the ring was full.
    pub records_dropped: u32,
    /// Replies dropped because the ring was full (only if replies come faster than the
    /// line drains them).
    pub replies_dropped: u32,
}

/// The link, with a transmit ring of `TX` bytes.
#[derive(Debug)]
pub struct Link<const TX: usize> {
    reader: FrameReader,
    requests: Deque<Request, REQUEST_SLOTS>,
    tx: Deque<u8, TX>,
    stats: LinkStats,
}

impl<const TX: usize> Default for Link<TX> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const TX: usize> Link<TX> {
    /// An idle link.
    pub const fn new() -> Self {
        Self {
            reader: FrameReader::new(),
            requests: Deque::new(),
            tx: Deque::new(),
            stats: LinkStats {
                bad_frames: 0,
                requests_refused: 0,
                records_dropped: 0,
                replies_dropped: 0,
            },
        }
    }

    /// Takes one received byte (from the receive interrupt).
    pub fn receive_byte(&mut self, byte: u8) {
        let Some(frame) = self.reader.push(byte) else {
            return;
        };
        let decoded = frame.and_then(decode::<Request>);
        match decoded {
            Ok(request) => {
                if let Err(request) = self.requests.push_back(request) {
                    self.stats.requests_refused = self.stats.requests_refused.saturating_add(1);
                    self.reply(&Reply {
                        seq: request.seq,
                        outcome: Outcome::Refused(beam_wire::command::Refusal::Busy),
                    });
                }
            }
            Err(e) => {
                self.stats.bad_frames = self.stats.bad_frames.saturating_add(1);
                self.reply(&Reply {
                    seq: 0,
                    outcome: Outcome::BadFrame(e),
                });
            }
        }
    }

    /// The oldest request waiting, for the link task.
    pub fn next_request(&mut self) -> Option<Request> {
        self.requests.pop_front()
    }

    /// Queues a reply. Returns false (and counts it) if the ring has no room.
    pub fn reply(&mut self, reply: &Reply) -> bool {
        let ok = self.queue(&Uplink::Reply(*reply), 0);
        if !ok {
            self.stats.replies_dropped = self.stats.replies_dropped.saturating_add(1);
        }
        ok
    }

    /// Queues a telemetry record if the ring keeps room for a reply after it; otherwise
    /// drops it and counts it. The record carries the drop count so far.
    pub fn record(&mut self, record: &Record) -> bool {
        let record = Record {
            dropped: self.stats.records_dropped,
            ..*record
        };
        let ok = self.queue(&Uplink::Record(record), MAX_FRAME + 1);
        if !ok {
            self.stats.records_dropped = self.stats.records_dropped.saturating_add(1);
        }
        ok
    }

    /// The next byte to transmit (for the transmit interrupt); `None` when the ring is empty.
    pub fn next_tx_byte(&mut self) -> Option<u8> {
        self.tx.pop_front()
    }

    /// Bytes waiting to be sent.
    pub fn tx_pending(&self) -> usize {
        self.tx.len()
    }

    /// What the link has counted.
    pub fn stats(&self) -> LinkStats {
        self.stats
    }

    /// Encodes `msg` into the ring if it fits with `reserve` bytes to spare; all or nothing.
    fn queue(&mut self, msg: &Uplink, reserve: usize) -> bool {
        let mut buf = [0u8; MAX_FRAME + 1];
        let Ok(frame) = encode(msg, &mut buf) else {
            return false;
        };
        if TX - self.tx.len() < frame.len() + reserve {
            return false;
        }
        for &b in frame {
            // Room was checked above.
            let _ = self.tx.push_back(b);
        }
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use beam_wire::command::{Command, Refusal};
    use beam_wire::FrameError;

    type TestLink = Link<1024>;

    fn frame_of(request: &Request) -> std::vec::Vec<u8> {
        let mut buf = [0u8; MAX_FRAME + 1];
        encode(request, &mut buf).unwrap().to_vec()
    }

    /// Everything in the transmit ring, decoded.
    fn sent(link: &mut TestLink) -> std::vec::Vec<Uplink> {
        let mut reader = FrameReader::new();
        let mut out = vec![];
        while let Some(b) = link.next_tx_byte() {
            if let Some(f) = reader.push(b) {
                out.push(decode::<Uplink>(f.unwrap()).unwrap());
            }
        }
        out
    }

    fn status(seq: u16) -> Request {
        Request {
            seq,
            command: Command::Status,
        }
    }

    #[test]
    fn requests_arrive_whole_and_a_bad_frame_is_answered_and_forgotten() {
        let mut link = TestLink::new();
        let good = frame_of(&status(7));
        let mut bad = frame_of(&status(8));
        bad[3] ^= 0x40; // a bit flip: the CRC no longer matches
        for &b in good.iter().chain(&bad).chain(&good) {
            link.receive_byte(b);
        }
        assert_eq!(link.next_request(), Some(status(7)));
        assert_eq!(link.next_request(), Some(status(7)));
        assert_eq!(link.next_request(), None);
        assert_eq!(link.stats().bad_frames, 1);
        match sent(&mut link).as_slice() {
            [Uplink::Reply(Reply {
                seq: 0,
                outcome: Outcome::BadFrame(FrameError::Crc { .. }),
            })] => {}
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn garbage_on_the_line_costs_nothing_but_the_frames_it_hits() {
        // Pseudo-random bytes with valid frames among them: every valid frame that follows a
        // delimiter arrives; nothing panics; the queue never grows past its slots.
        let mut link = TestLink::new();
        let mut x = 0x1234_5678u32;
        let mut expected = 0;
        for i in 0..2000u16 {
            for _ in 0..(i % 50) {
                x ^= x << 13;
                x ^= x >> 17;
                x ^= x << 5;
                link.receive_byte(x as u8);
                while link.next_tx_byte().is_some() {}
            }
            link.receive_byte(0);
            for b in frame_of(&status(i)) {
                link.receive_byte(b);
            }
            expected += 1;
            let mut got = 0;
            while let Some(r) = link.next_request() {
                assert_eq!(r, status(i));
                got += 1;
            }
            assert_eq!(got, 1, "frame {i}");
            while link.next_tx_byte().is_some() {}
        }
        assert_eq!(expected, 2000);
        assert!(link.stats().bad_frames > 0);
    }

    #[test]
    fn a_full_request_queue_answers_busy_at_once() {
        let mut link = TestLink::new();
        for seq in 1..=(REQUEST_SLOTS as u16 + 1) {
            for b in frame_of(&status(seq)) {
                link.receive_byte(b);
            }
        }
        assert_eq!(link.stats().requests_refused, 1);
        match sent(&mut link).as_slice() {
            [Uplink::Reply(r)] => {
                assert_eq!(r.seq, REQUEST_SLOTS as u16 + 1);
                assert_eq!(r.outcome, Outcome::Refused(Refusal::Busy));
            }
            other => panic!("{other:?}"),
        }
    }

    /// Ticks of streaming at `baud` (10 bits a byte on the line), a record every tick and a
    /// reply every 100: (records dropped, replies dropped).
    fn stream(baud: u32, ticks: u32) -> (u32, u32) {
        let mut link = Link::<512>::new();
        let per_tick = baud as f64 / 10.0 / 1000.0;
        let mut budget = 0.0;
        for tick in 0..ticks {
            // Widest values: every varint and float at full length.
            let r = Record {
                tick: u32::MAX - tick,
                torque_nm: -9.999,
                theta_rad: -core::f32::consts::PI,
                theta_ref_rad: core::f32::consts::PI,
                strain: -1.23e-4,
                mode: 3,
                faults: 0xFF,
                dropped: 0,
            };
            link.record(&r);
            if tick % 100 == 0 {
                link.reply(&Reply {
                    seq: tick as u16,
                    outcome: Outcome::Refused(Refusal::TooFast { needs_s: 0.5 }),
                });
            }
            budget += per_tick;
            while budget >= 1.0 && link.next_tx_byte().is_some() {
                budget -= 1.0;
            }
            budget = budget.min(per_tick);
        }
        (link.stats().records_dropped, link.stats().replies_dropped)
    }

    #[test]
    fn a_1_khz_stream_fits_the_line_and_a_slow_line_sheds_records_not_replies() {
        // The widest record frame is within RECORD_FRAME_MAX.
        let mut buf = [0u8; MAX_FRAME + 1];
        let widest = Uplink::Record(Record {
            tick: u32::MAX,
            dropped: u32::MAX,
            mode: 255,
            faults: 255,
            torque_nm: f32::MIN,
            ..Record::default()
        });
        assert!(encode(&widest, &mut buf).unwrap().len() <= RECORD_FRAME_MAX);
        assert_eq!(stream(BAUD, 10_000), (0, 0));
        // At a quarter of the rate the line carries 23 bytes a tick, less than a record:
        // records are shed and counted, replies all go out. No more records can have gone
        // than the line carried (bytes are conserved): sent <= (line bytes + ring) / frame.
        let ticks = 10_000;
        let (records, replies) = stream(BAUD / 4, ticks);
        assert_eq!(replies, 0);
        let frame = {
            let r = Uplink::Record(Record {
                tick: u32::MAX - 5000,
                torque_nm: -9.999,
                ..Record::default()
            });
            encode(&r, &mut buf).unwrap().len() as f64
        };
        let line = (BAUD / 4) as f64 / 10.0 / 1000.0 * ticks as f64;
        let most_sent = ((line + 512.0) / frame).ceil() as u32;
        assert!(
            records >= ticks - most_sent,
            "{records} dropped, at most {most_sent} sent"
        );
        assert!(records < ticks, "some records go out");
    }
}
