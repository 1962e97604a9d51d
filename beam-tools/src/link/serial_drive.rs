//! A drive on a serial port: the host's end of `beam_drive::link` (requests out; replies and
//! telemetry records in), over any byte stream, a `serialport` port on the bench or a
//! pseudo-terminal in the tests.

use beam_wire::command::{Command, Record, Reply, Request, Uplink};
use beam_wire::{decode, encode, FrameError, FrameReader, MAX_FRAME};
use std::io::{Read, Write};
use std::time::{Duration, Instant};

/// What can go wrong talking to a drive.
#[derive(Debug, thiserror::Error)]
pub enum LinkError {
    /// The port could not be opened.
    #[error("opening {port}")]
    Open {
        /// The port.
        port: String,
        /// Why.
        #[source]
        source: serialport::Error,
    },
    /// Reading or writing failed.
    #[error("serial I/O")]
    Io(#[from] std::io::Error),
    /// No reply to a request in time.
    #[error(
        "no reply to request {seq} within {timeout_ms} ms: the drive may have received it and \
         be carrying it out (a move may be running); ask it with `status`"
    )]
    Timeout {
        /// The request's sequence number.
        seq: u16,
        /// How long we waited, ms.
        timeout_ms: u64,
    },
    /// A request could not be encoded (a bug).
    #[error("encoding a request")]
    Encode(#[source] FrameError),
    /// The drive could not decode a request we sent.
    #[error("the drive could not read request {seq}: {error}")]
    Rejected {
        /// The request.
        seq: u16,
        /// What the drive said.
        error: FrameError,
    },
}

/// A drive at the other end of `port`.
pub struct SerialDrive<P> {
    port: P,
    reader: FrameReader,
    seq: u16,
    timeout: Duration,
    records: Vec<Record>,
    bad_frames: u32,
    progress: Option<Box<dyn FnMut(usize)>>,
    last_progress: Instant,
}

impl SerialDrive<Box<dyn serialport::SerialPort>> {
    /// Opens `path` at `baud` (8N1), waiting up to `timeout` for each reply.
    pub fn open(path: &str, baud: u32, timeout: Duration) -> Result<Self, LinkError> {
        let port = serialport::new(path, baud)
            .timeout(Duration::from_millis(5))
            .open()
            .map_err(|source| LinkError::Open {
                port: path.to_string(),
                source,
            })?;
        // Whatever the line holds from before this run (a late reply to another run's
        // request, the drive's stream) is not for this run.
        port.clear(serialport::ClearBuffer::Input)
            .map_err(|source| LinkError::Open {
                port: path.to_string(),
                source,
            })?;
        Ok(Self::new(port, timeout))
    }
}

impl<P: Read + Write> SerialDrive<P> {
    /// A drive on `port` (whose reads should time out after a few milliseconds). Each run
    /// numbers its requests from a random start, so a late reply to another run's request
    /// (one that timed out there) is never taken for a reply to this run's.
    pub fn new(port: P, timeout: Duration) -> Self {
        Self {
            port,
            reader: FrameReader::new(),
            seq: rand::random::<u16>(),
            timeout,
            records: vec![],
            bad_frames: 0,
            progress: None,
            last_progress: Instant::now(),
        }
    }

    /// Calls `f` with the number of records received, at most ten times a second while
    /// they arrive (for a progress line).
    pub fn on_progress(&mut self, f: impl FnMut(usize) + 'static) {
        self.progress = Some(Box::new(f));
    }

    /// Sends `command` and waits for its reply, keeping the records that arrive meanwhile.
    pub fn request(&mut self, command: Command) -> Result<(Request, Reply), LinkError> {
        self.seq = self.seq.wrapping_add(1).max(1);
        let request = Request {
            seq: self.seq,
            command,
        };
        let mut buf = [0u8; MAX_FRAME + 1];
        let frame = encode(&request, &mut buf).map_err(LinkError::Encode)?;
        // A delimiter first: it ends whatever stray bytes the line carried before (the
        // drive skips the empty frame it makes), so they cannot spoil this request.
        self.port.write_all(&[0])?;
        self.port.write_all(frame)?;
        self.port.flush()?;
        let deadline = Instant::now() + self.timeout;
        // A frame the drive could not read is answered with sequence 0: it may be ours, or
        // stray bytes the line carried before it (which our leading delimiter cut off into
        // a frame of their own). Ours is known only when no reply to it comes.
        let mut rejected = None;
        while Instant::now() < deadline {
            for up in self.read_some()? {
                match up {
                    Uplink::Reply(r) if r.seq == request.seq => return Ok((request, r)),
                    Uplink::Reply(Reply {
                        seq: 0,
                        outcome: beam_wire::command::Outcome::BadFrame(error),
                    }) => rejected = Some(error),
                    // A late reply to an earlier request: not ours.
                    Uplink::Reply(_) => {}
                    Uplink::Record(r) => self.records.push(r),
                }
            }
        }
        Err(match rejected {
            Some(error) => LinkError::Rejected {
                seq: request.seq,
                error,
            },
            None => LinkError::Timeout {
                seq: request.seq,
                timeout_ms: self.timeout.as_millis() as u64,
            },
        })
    }

    /// Reads for `for_`, keeping the records.
    pub fn listen(&mut self, for_: Duration) -> Result<(), LinkError> {
        let until = Instant::now() + for_;
        while Instant::now() < until {
            for up in self.read_some()? {
                if let Uplink::Record(r) = up {
                    self.records.push(r);
                }
            }
        }
        Ok(())
    }

    /// The records received so far (taken).
    pub fn take_records(&mut self) -> Vec<Record> {
        std::mem::take(&mut self.records)
    }

    /// Frames from the drive that did not decode.
    pub fn bad_frames(&self) -> u32 {
        self.bad_frames
    }

    /// Whatever frames the port has now (waits at most its read timeout).
    fn read_some(&mut self) -> Result<Vec<Uplink>, LinkError> {
        let mut buf = [0u8; 256];
        let n = match self.port.read(&mut buf) {
            Ok(n) => n,
            Err(e)
                if matches!(
                    e.kind(),
                    std::io::ErrorKind::TimedOut | std::io::ErrorKind::WouldBlock
                ) =>
            {
                0
            }
            Err(e) => return Err(e.into()),
        };
        if let Some(f) = &mut self.progress {
            if self.last_progress.elapsed() >= Duration::from_millis(100) {
                self.last_progress = Instant::now();
                f(self.records.len());
            }
        }
        let mut out = vec![];
        for &b in &buf[..n] {
            match self.reader.push(b) {
                Some(Ok(frame)) => match decode::<Uplink>(frame) {
                    Ok(up) => out.push(up),
                    Err(_) => self.bad_frames += 1,
                },
                Some(Err(_)) => self.bad_frames += 1,
                None => {}
            }
        }
        Ok(out)
    }
}

/// Records as the CSV `beam calibrate` reads (`t_s` from the first record's tick at
/// `ts_s`), with the drive's reference, mode, faults and drop count.
pub fn write_records_csv(records: &[Record], ts_s: f64, w: &mut dyn Write) -> std::io::Result<()> {
    writeln!(
        w,
        "t_s,tick,torque_nm,theta_rad,theta_ref_rad,root_strain,mode,faults,dropped"
    )?;
    let Some(first) = records.first() else {
        return Ok(());
    };
    for r in records {
        let k = r.tick.wrapping_sub(first.tick) as usize;
        writeln!(
            w,
            "{},{},{},{},{},{},{},{},{}",
            beam_sim::decimal::tick_time(k, ts_s),
            r.tick,
            r.torque_nm,
            r.theta_rad,
            r.theta_ref_rad,
            r.strain,
            r.mode,
            r.faults,
            r.dropped
        )?;
    }
    Ok(())
}
