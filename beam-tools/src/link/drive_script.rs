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
        let err = |message: String| ScriptError {
            line: i + 1,
            message,
        };
        let words: Vec<&str> = line.split_whitespace().collect();
        let arg = |k: usize, what: &str| -> Result<f64, ScriptError> {
            let w = words
                .get(k)
                .ok_or_else(|| err(format!("`{}` needs {what}", quoted(words[0]))))?;
            w.parse::<f64>()
                .ok()
                .filter(|x| x.is_finite())
                .ok_or_else(|| err(format!("`{}` is not a number ({what})", quoted(w))))
        };
        let time = |k: usize| -> Result<Option<f32>, ScriptError> {
            match words.get(k) {
                None => Ok(None),
                Some(_) => {
                    let t = arg(k, "a time in s")?;
                    if t > 0.0 {
                        Ok(Some(t as f32))
                    } else {
                        Err(err(format!("time {t} must be positive")))
                    }
                }
            }
        };
        let nargs = |max: usize| {
            if words.len() > max + 1 {
                Err(err(format!(
                    "`{}` takes at most {max} arguments",
                    quoted(words[0])
                )))
            } else {
                Ok(())
            }
        };
        let step = match words[0] {
            "move" => {
                nargs(2)?;
                Step::Send(Command::MoveTo {
                    to_rad: (arg(1, "an angle in deg")?.to_radians()) as f32,
                    time_s: time(2)?,
                })
            }
            "through" => {
                nargs(2)?;
                let list = words
                    .get(1)
                    .ok_or_else(|| err("`through` needs angles, DEG,DEG,...".into()))?;
                let mut waypoints = heapless::Vec::<Waypoint, MAX_WAYPOINTS>::new();
                for a in list.split(',') {
                    let deg: f64 = a
                        .parse()
                        .ok()
                        .filter(|x: &f64| x.is_finite())
                        .ok_or_else(|| err(format!("`{}` is not an angle", quoted(a))))?;
                    waypoints
                        .push(Waypoint {
                            rad: deg.to_radians() as f32,
                            at_s: None,
                        })
                        .map_err(|_| err(format!("at most {MAX_WAYPOINTS} waypoints")))?;
                }
                Step::Send(Command::MoveThrough {
                    waypoints,
                    time_s: time(2)?,
                })
            }
            "payload" => {
                nargs(1)?;
                Step::Send(Command::SetPayload {
                    kg: arg(1, "a mass in kg")? as f32,
                })
            }
            "stop" | "disable" | "clear" | "status" => {
                nargs(0)?;
                Step::Send(match words[0] {
                    "stop" => Command::Stop,
                    "disable" => Command::Disable,
                    "clear" => Command::ClearFault,
                    _ => Command::Status,
                })
            }
            "stream" => {
                nargs(1)?;
                let n = arg(1, "ticks per record")?;
                if !(0.0..=u16::MAX as f64).contains(&n) || n.fract() != 0.0 {
                    return Err(err(format!("`stream {n}`: a whole number 0..=65535")));
                }
                Step::Send(Command::Stream { every: n as u16 })
            }
            "wait" => {
                nargs(1)?;
                let s = arg(1, "seconds")?;
                if !(0.0..=MAX_WAIT_S).contains(&s) {
                    return Err(err(format!("`wait {s}`: 0 to {MAX_WAIT_S} s")));
                }
                Step::Wait(s)
            }
            "done" => {
                nargs(1)?;
                let settle_s = if words.len() > 1 {
                    arg(1, "seconds")?
                } else {
                    0.4
                };
                if !(0.0..=MAX_WAIT_S).contains(&settle_s) {
                    return Err(err(format!("`done {settle_s}`: 0 to {MAX_WAIT_S} s")));
                }
                Step::UntilDone {
                    settle_s,
                    max_s: 60.0,
                }
            }
            "attach" => {
                nargs(1)?;
                let kg = arg(1, "a mass in kg")?;
                if !(0.0..=1.0).contains(&kg) {
                    return Err(err(format!("`attach {kg}`: 0 to 1 kg")));
                }
                Step::Attach(kg)
            }
            "fault" => {
                nargs(1)?;
                let n = arg(1, "ticks")?;
                if !(0.0..=1e6).contains(&n) || n.fract() != 0.0 {
                    return Err(err(format!("`fault {n}`: a whole number of ticks")));
                }
                Step::AmpFault(n as u32)
            }
            "load" => {
                nargs(1)?;
                let nm = arg(1, "a torque in N m")?;
                if !(-100.0..=100.0).contains(&nm) {
                    return Err(err(format!("`load {nm}`: -100 to 100 N m")));
                }
                Step::Load(nm)
            }
            "sensor" => {
                nargs(3)?;
                let what = words.get(1).copied().unwrap_or("");
                let how = words.get(2).copied().unwrap_or("");
                let fault = match (what, how) {
                    ("ok", "") => SensorFault::None,
                    ("gauge", "ok") | ("encoder", "ok") => SensorFault::None,
                    ("gauge", "stuck") => SensorFault::GaugeStuck,
                    ("gauge", "zero") => SensorFault::GaugeZero,
                    ("gauge", "reversed") => SensorFault::GaugeReversed,
                    ("gauge", "gain") => {
                        let k = arg(3, "a gain")?;
                        if !(-1e3..=1e3).contains(&k) {
                            return Err(err(format!("`sensor gauge gain {k}`: -1000 to 1000")));
                        }
                        SensorFault::GaugeGain(k)
                    }
                    ("gauge", "bias") => {
                        let ue = arg(3, "a strain in microstrain")?;
                        if !(-1e5..=1e5).contains(&ue) {
                            return Err(err(format!(
                                "`sensor gauge bias {ue}`: -100000 to 100000 ue"
                            )));
                        }
                        SensorFault::GaugeBias(ue * 1e-6)
                    }
                    ("encoder", "stuck") => SensorFault::EncoderStuck,
                    ("encoder", "jump") => {
                        let n = arg(3, "a number of counts")?;
                        if !(-1e9..=1e9).contains(&n) || n.fract() != 0.0 {
                            return Err(err(format!(
                                "`sensor encoder jump {n}`: a whole number of counts"
                            )));
                        }
                        SensorFault::EncoderJump(n as i64)
                    }
                    _ => {
                        return Err(err(format!(
                            "`sensor {}`: `sensor gauge stuck|zero|reversed|gain K|bias UE|ok`, \
                             `sensor encoder stuck|jump COUNTS|ok` or `sensor ok`",
                            quoted(&words[1..].join(" "))
                        )))
                    }
                };
                let takes = match fault {
                    SensorFault::GaugeGain(_)
                    | SensorFault::GaugeBias(_)
                    | SensorFault::EncoderJump(_) => 3,
                    _ if what == "ok" => 1,
                    _ => 2,
                };
                nargs(takes)?;
                Step::Sensor(fault)
            }
            "latency" => {
                nargs(1)?;
                let n = arg(1, "ticks")?;
                if !(0.0..=1000.0).contains(&n) || n.fract() != 0.0 {
                    return Err(err(format!(
                        "`latency {n}`: a whole number of ticks, 0 to 1000"
                    )));
                }
                Step::Latency(n as u32)
            }
            other => return Err(err(format!("unknown command `{}`", quoted(other)))),
        };
        steps.push(step);
    }
    Ok(steps)
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
            ("sensor gauge gain", "needs a gain"),
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
