//! The command scripts `beam drive` runs: one command per line, `#` starts a comment.
//!
//! ```text
//! move DEG [S]             MoveTo DEG, in S seconds or the shortest time
//! through DEG,DEG,... [S]  MoveThrough the angles (the last is the target)
//! payload KG               SetPayload
//! stop | disable | clear | status
//! stream N                 telemetry every N ticks (0: off)
//! wait S                   let S seconds pass
//! done [S]                 wait for the move to end, then S more seconds (default 0.4)
//! attach KG                (simulated beam only) the payload the beam really carries
//! fault N                  (simulated beam only) the amplifier's fault line for N ticks
//! load NM                  (simulated beam only) a constant torque on the hub from now on
//! sensor gauge stuck|zero|reversed|gain K|bias UE|ok
//!                          (simulated beam only) the strain gauge fails so from now on
//! sensor encoder stuck|jump COUNTS|ok
//!                          (simulated beam only) the encoder fails so from now on
//! sensor ok                (simulated beam only) both sensors read true again
//! latency N                (host drive only) each command planned N ticks before it applies
//! quit | exit              the script ends here
//! ```

use beam_sim::commanded::Step;
use beam_sim::sensors::SensorFault;
use beam_wire::command::{Command, Waypoint, MAX_WAYPOINTS};

/// A script line that could not be read.
#[derive(Debug, PartialEq, thiserror::Error)]
#[error("line {line}: {message}")]
pub struct ScriptError {
    /// 1-based line number.
    pub line: usize,
    /// What is wrong.
    pub message: String,
}

/// Longest wait a script may ask for, s.
const MAX_WAIT_S: f64 = 600.0;

/// Longest piece of a script's text an error message quotes, characters.
const QUOTED_CHARS: usize = 24;

/// A word of the script as an error message quotes it: escaped (no control characters or
/// terminal escapes reach the terminal) and cut to [`QUOTED_CHARS`].
fn quoted(word: &str) -> String {
    let mut out: String = word.chars().take(QUOTED_CHARS).collect();
    if word.chars().count() > QUOTED_CHARS {
        out.push_str("...");
    }
    out.escape_debug().to_string()
}

/// Reads a script (a UTF-8 byte-order mark at its start is skipped).
pub fn parse(text: &str) -> Result<Vec<Step>, ScriptError> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let mut steps = vec![];
    for (i, raw) in text.lines().enumerate() {
        if is_quit(raw) {
            break;
        }
        let line = raw.split('#').next().unwrap_or("").trim();
        if line.is_empty() {
            continue;
        }
        let line = Line {
            no: i + 1,
            words: line.split_whitespace().collect(),
        };
        steps.push(line.step()?);
    }
    Ok(steps)
}

/// One line of a script, in words (at least one), and its number.
struct Line<'a> {
    no: usize,
    words: Vec<&'a str>,
}

impl Line<'_> {
    /// An error on this line.
    fn err(&self, message: String) -> ScriptError {
        ScriptError {
            line: self.no,
            message,
        }
    }

    /// Word `k` as a finite number (`what` says what it should be).
    fn arg(&self, k: usize, what: &str) -> Result<f64, ScriptError> {
        let w = self.words.get(k).ok_or_else(|| {
            let command = self.words[..k.min(self.words.len())].join(" ");
            self.err(format!("`{}` needs {what}", quoted(&command)))
        })?;
        w.parse::<f64>()
            .ok()
            .filter(|x| x.is_finite())
            .ok_or_else(|| self.err(format!("`{}` is not a number ({what})", quoted(w))))
    }

    /// Word `k`, if there, as a positive time in s.
    fn time(&self, k: usize) -> Result<Option<f32>, ScriptError> {
        if self.words.get(k).is_none() {
            return Ok(None);
        }
        let t = self.arg(k, "a time in s")?;
        if t > 0.0 {
            Ok(Some(t as f32))
        } else {
            Err(self.err(format!("time {t} must be positive")))
        }
    }

    /// At most `max` words after the command.
    fn nargs(&self, max: usize) -> Result<(), ScriptError> {
        if self.words.len() > max + 1 {
            Err(self.err(format!(
                "`{}` takes at most {max} arguments",
                quoted(self.words[0])
            )))
        } else {
            Ok(())
        }
    }

    /// Word `k` as a number within `range` (`what` says what it should be; `whole`: an
    /// integer), or an error quoting the line's command and the range.
    fn number_in(
        &self,
        k: usize,
        what: &str,
        range: core::ops::RangeInclusive<f64>,
        whole: bool,
    ) -> Result<f64, ScriptError> {
        let x = self.arg(k, what)?;
        if !range.contains(&x) || (whole && x.fract() != 0.0) {
            return Err(self.err(format!(
                "`{} {x}`: {}{} to {}",
                self.words[..k].join(" "),
                if whole { "a whole number, " } else { "" },
                range.start(),
                range.end()
            )));
        }
        Ok(x)
    }

    /// The step this line asks for.
    fn step(&self) -> Result<Step, ScriptError> {
        let words = &self.words;
        Ok(match words[0] {
            "move" => {
                self.nargs(2)?;
                Step::Send(Command::MoveTo {
                    to_rad: (self.arg(1, "an angle in deg")?.to_radians()) as f32,
                    time_s: self.time(2)?,
                })
            }
            "through" => {
                self.nargs(2)?;
                let list = words
                    .get(1)
                    .ok_or_else(|| self.err("`through` needs angles, DEG,DEG,...".into()))?;
                let mut waypoints = heapless::Vec::<Waypoint, MAX_WAYPOINTS>::new();
                for a in list.split(',') {
                    let deg: f64 = a
                        .parse()
                        .ok()
                        .filter(|x: &f64| x.is_finite())
                        .ok_or_else(|| self.err(format!("`{}` is not an angle", quoted(a))))?;
                    waypoints
                        .push(Waypoint {
                            rad: deg.to_radians() as f32,
                            at_s: None,
                        })
                        .map_err(|_| self.err(format!("at most {MAX_WAYPOINTS} waypoints")))?;
                }
                Step::Send(Command::MoveThrough {
                    waypoints,
                    time_s: self.time(2)?,
                })
            }
            "payload" => {
                self.nargs(1)?;
                Step::Send(Command::SetPayload {
                    kg: self.arg(1, "a mass in kg")? as f32,
                })
            }
            "stop" | "disable" | "clear" | "status" => {
                self.nargs(0)?;
                Step::Send(match words[0] {
                    "stop" => Command::Stop,
                    "disable" => Command::Disable,
                    "clear" => Command::ClearFault,
                    _ => Command::Status,
                })
            }
            "stream" => {
                self.nargs(1)?;
                let n = self.number_in(1, "ticks per record", 0.0..=u16::MAX as f64, true)?;
                Step::Send(Command::Stream { every: n as u16 })
            }
            "wait" => {
                self.nargs(1)?;
                Step::Wait(self.number_in(1, "seconds", 0.0..=MAX_WAIT_S, false)?)
            }
            "done" => {
                self.nargs(1)?;
                let settle_s = if words.len() > 1 {
                    self.number_in(1, "seconds", 0.0..=MAX_WAIT_S, false)?
                } else {
                    0.4
                };
                Step::UntilDone {
                    settle_s,
                    max_s: 60.0,
                }
            }
            "attach" => {
                self.nargs(1)?;
                Step::Attach(self.number_in(1, "a mass in kg", 0.0..=1.0, false)?)
            }
            "fault" => {
                self.nargs(1)?;
                Step::AmpFault(self.number_in(1, "ticks", 0.0..=1e6, true)? as u32)
            }
            "load" => {
                self.nargs(1)?;
                Step::Load(self.number_in(1, "a torque in N m", -100.0..=100.0, false)?)
            }
            "sensor" => Step::Sensor(self.sensor_fault()?),
            "latency" => {
                self.nargs(1)?;
                Step::Latency(self.number_in(1, "ticks", 0.0..=1000.0, true)? as u32)
            }
            other => return Err(self.err(format!("unknown command `{}`", quoted(other)))),
        })
    }

    /// `sensor gauge|encoder FAULT [N]` or `sensor ok`.
    fn sensor_fault(&self) -> Result<SensorFault, ScriptError> {
        let what = self.words.get(1).copied().unwrap_or("");
        let how = self.words.get(2).copied().unwrap_or("");
        let (fault, takes) = match (what, how) {
            ("ok", "") => (SensorFault::None, 1),
            ("gauge" | "encoder", "ok") => (SensorFault::None, 2),
            ("gauge", "stuck") => (SensorFault::GaugeStuck, 2),
            ("gauge", "zero") => (SensorFault::GaugeZero, 2),
            ("gauge", "reversed") => (SensorFault::GaugeReversed, 2),
            ("gauge", "gain") => (
                SensorFault::GaugeGain(self.number_in(3, "a gain", -1e3..=1e3, false)?),
                3,
            ),
            ("gauge", "bias") => {
                let ue = self.number_in(3, "a strain in microstrain", -1e5..=1e5, false)?;
                (SensorFault::GaugeBias(ue * 1e-6), 3)
            }
            ("encoder", "stuck") => (SensorFault::EncoderStuck, 2),
            ("encoder", "jump") => {
                let n = self.number_in(3, "a number of counts", -1e9..=1e9, true)?;
                (SensorFault::EncoderJump(n as i64), 3)
            }
            _ => {
                return Err(self.err(format!(
                    "`sensor {}`: `sensor gauge stuck|zero|reversed|gain K|bias UE|ok`, \
                     `sensor encoder stuck|jump COUNTS|ok` or `sensor ok`",
                    quoted(&self.words[1..].join(" "))
                )))
            }
        };
        self.nargs(takes)?;
        Ok(fault)
    }
}

/// `quit` or `exit` (alone on its line, a comment allowed): the script ends there.
pub fn is_quit(line: &str) -> bool {
    matches!(line.split('#').next().unwrap_or("").trim(), "quit" | "exit")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_command_reads_and_bad_lines_name_their_line() {
        let steps = parse(
            "# a session\nmove 45\nmove -90 0.4  # timed\nthrough 10,-30\npayload 0.025\n\
             stop\ndisable\nclear\nstatus\nstream 10\nwait 0.5\ndone\ndone 1\nattach 0.02\nfault 3\n",
        )
        .unwrap();
        assert_eq!(steps.len(), 14);
        assert_eq!(
            steps[1],
            Step::Send(Command::MoveTo {
                to_rad: (-90f64).to_radians() as f32,
                time_s: Some(0.4)
            })
        );
        match &steps[2] {
            Step::Send(Command::MoveThrough { waypoints, time_s }) => {
                assert_eq!(waypoints.len(), 2);
                assert_eq!(*time_s, None);
            }
            other => panic!("{other:?}"),
        }
        for (text, says) in [
            ("move", "needs"),
            ("move x", "not a number"),
            ("move 1 0", "positive"),
            ("move 1 2 3", "at most"),
            ("through 1,,2", "not an angle"),
            ("through 1,2,3,4,5,6,7,8,9", "at most 8"),
            ("stream -1", "whole number"),
            ("wait 1e9", "0 to"),
            ("jump 3", "unknown command"),
            ("move nan", "not a number"),
            ("load", "needs"),
            ("load 1e3", "-100 to 100"),
            ("sensor gauge", "sensor gauge stuck"),
            ("sensor gauge melted", "sensor gauge stuck"),
            ("sensor gauge gain", "`sensor gauge gain` needs a gain"),
            ("sensor gauge stuck 3", "at most 2"),
            ("sensor encoder jump 1.5", "whole number"),
            ("sensor ok now", "or `sensor ok`"),
            ("latency 2.5", "whole number"),
        ] {
            let e = parse(&format!("status\n{text}")).unwrap_err();
            assert_eq!(e.line, 2, "{text}");
            assert!(e.message.contains(says), "{text}: {e}");
        }
    }

    #[test]
    fn quit_ends_a_script_where_it_stands() {
        let steps = parse("status\nquit  # done\nmove 10\nnonsense\n").unwrap();
        assert_eq!(steps, vec![Step::Send(Command::Status)]);
        assert_eq!(parse("exit\nmove 10\n").unwrap(), vec![]);
        assert!(is_quit(" quit ") && is_quit("exit # bye") && !is_quit("quitter"));
    }

    #[test]
    fn the_simulated_worlds_commands_read() {
        let steps = parse(
            "load 0.5\nload -2\nsensor gauge stuck\nsensor gauge zero\nsensor gauge reversed\n\
             sensor gauge gain 3\nsensor gauge bias 1000\nsensor encoder stuck\n\
             sensor encoder jump -40\nsensor gauge ok\nsensor ok\nlatency 5\n",
        )
        .unwrap();
        assert_eq!(
            steps,
            vec![
                Step::Load(0.5),
                Step::Load(-2.0),
                Step::Sensor(SensorFault::GaugeStuck),
                Step::Sensor(SensorFault::GaugeZero),
                Step::Sensor(SensorFault::GaugeReversed),
                Step::Sensor(SensorFault::GaugeGain(3.0)),
                Step::Sensor(SensorFault::GaugeBias(1000.0 * 1e-6)),
                Step::Sensor(SensorFault::EncoderStuck),
                Step::Sensor(SensorFault::EncoderJump(-40)),
                Step::Sensor(SensorFault::None),
                Step::Sensor(SensorFault::None),
                Step::Latency(5),
            ]
        );
    }

    #[test]
    fn errors_quote_the_script_escaped_and_bounded_and_a_byte_order_mark_is_skipped() {
        // A script saved with a BOM reads as without.
        assert_eq!(
            parse("\u{feff}status\n").unwrap(),
            parse("status\n").unwrap()
        );
        // A megabyte word: the message stays short.
        let long = "x".repeat(1 << 20);
        let e = parse(&long).unwrap_err().to_string();
        assert!(e.len() < 100, "{} bytes", e.len());
        assert!(e.contains("..."), "{e}");
        // Terminal escapes and other control bytes are escaped, not printed raw.
        let e = parse("\u{1b}[2Jmove 1\n").unwrap_err().to_string();
        assert!(!e.contains('\u{1b}'), "{e:?}");
        assert!(e.contains("\\u{1b}"), "{e}");
    }
}
