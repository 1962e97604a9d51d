//! A rig's logged moves, as the calibration reads them: a CSV of uniformly sampled time,
//! applied torque, measured hub angle and the beam's signal (root strain or tip deflection),
//! with each quantity's column and unit mapped ([`Columns`]). Errors name the file, the line
//! and the column.
//!
//! Its own crate so that what reads a user's file can be fuzzed without building the
//! calibration, the plots and the serial link around it.

use beam_model::ModalModel;

/// A log that cannot be calibrated on: the file, the line (1-based) where there is one, and
/// the problem.
#[derive(Debug, thiserror::Error)]
#[error("{file}{}: {problem}", line.map(|l| format!(": line {l}")).unwrap_or_default())]
pub struct LogError {
    /// The file, as given.
    pub file: String,
    /// The line, if the problem is on one.
    pub line: Option<usize>,
    /// What is wrong.
    pub problem: LogProblem,
}

/// What is wrong with a log.
#[derive(Debug, thiserror::Error)]
pub enum LogProblem {
    /// No header.
    #[error("empty file")]
    Empty,
    /// A required column is missing.
    #[error("no `{column}` column (header: {header})")]
    MissingColumn {
        /// The column.
        column: String,
        /// The header line.
        header: String,
    },
    /// A row with the wrong number of fields.
    #[error("{got} fields, the header has {header}")]
    FieldCount {
        /// Fields in the row.
        got: usize,
        /// Fields in the header.
        header: usize,
    },
    /// A field that is not a number.
    #[error("column `{column}`: `{text}` is not a number")]
    NotANumber {
        /// The column.
        column: String,
        /// What was there.
        text: String,
    },
    /// A NaN or infinite value.
    #[error("column `{column}`: {value} is not finite")]
    NonFinite {
        /// The column.
        column: String,
        /// The value.
        value: f64,
    },
    /// Time that stands still or goes back.
    #[error("column `t_s`: time {0} does not increase")]
    TimeNotIncreasing(f64),
    /// A change of sample period.
    #[error("column `t_s`: the sample period changes (uniform sampling needed)")]
    NonUniform,
    /// Too few samples.
    #[error("{0} samples: at least 100 (0.1 s at 1 kHz) are needed")]
    TooShort(usize),
    /// The log stops before the hub has settled after the move.
    #[error("the log ends {0:.3} s after the move: at least 0.05 s of settling is needed (log longer, or end the log before a move that is cut off: --to)")]
    EndsEarly(f64),
    /// The hub hardly moves in the log.
    #[error("the hub moves only {0:.4} rad in the log: no move to calibrate on")]
    NoMove(f64),
    /// Windows given by hand that do not fit the log.
    #[error(
        "the windows must satisfy 0 <= start < end < settle end <= {0:.3} s (the log's length)"
    )]
    BadWindows(f64),
}

/// What a log's beam signal measures: the calibration fits the beam to whichever the rig has.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum BeamSensor {
    /// Strain at the root gauge (the beam's surface, at the gauge's position), strain.
    #[default]
    RootStrain,
    /// The free end's deflection from the hub's line (the beam's elastic deflection at its
    /// tip, as an optical arm or a camera on the hub reads it), m. The model reads it through
    /// the mode shapes at the free end.
    TipDeflection,
}

impl BeamSensor {
    /// The modal model's row for this signal: root strain or tip deflection per unit of
    /// each modal coordinate.
    pub fn coef<const N: usize>(self, model: &ModalModel<N>) -> [f64; N] {
        match self {
            BeamSensor::RootStrain => model.root_strain_coef,
            BeamSensor::TipDeflection => model.tip_coef,
        }
    }

    /// The unit reports give this signal in ([`BeamSensor::unit`]) per SI unit.
    pub fn display_scale(self) -> f64 {
        match self {
            BeamSensor::RootStrain => 1e6,
            BeamSensor::TipDeflection => 1e3,
        }
    }

    /// The unit reports give this signal in: `ue` or `mm`.
    pub fn unit(self) -> &'static str {
        match self {
            BeamSensor::RootStrain => "ue",
            BeamSensor::TipDeflection => "mm",
        }
    }

    /// What the signal is, in words.
    pub fn name(self) -> &'static str {
        match self {
            BeamSensor::RootStrain => "root strain",
            BeamSensor::TipDeflection => "tip deflection",
        }
    }

    /// The signal's short name in JSON keys and CSV columns: `strain` or `tip`.
    pub fn key(self) -> &'static str {
        match self {
            BeamSensor::RootStrain => "strain",
            BeamSensor::TipDeflection => "tip",
        }
    }
}

/// A logged run: uniformly sampled time, applied torque, measured hub angle and the beam's
/// signal (root strain or tip deflection).
#[derive(Clone, Debug, PartialEq)]
pub struct Log {
    /// Sample times, s (uniform).
    pub t: Vec<f64>,
    /// Torque applied over the following sample, N m.
    pub torque: Vec<f64>,
    /// Measured hub angle, rad.
    pub theta: Vec<f64>,
    /// The beam's measured signal, in SI units: what `sensor` says.
    pub beam_signal: Vec<f64>,
    /// What `beam_signal` measures.
    pub sensor: BeamSensor,
    /// Mid-span strain, if logged.
    pub mid_strain: Option<Vec<f64>>,
}

/// Which column of a log holds each quantity, and in what unit (a multiplier to SI).
#[derive(Clone, Debug, PartialEq)]
pub struct Columns {
    /// Time: column and unit (s per unit).
    pub t: (String, f64),
    /// Torque: column and unit (N m per unit).
    pub torque: (String, f64),
    /// Hub angle: column and unit (rad per unit).
    pub theta: (String, f64),
    /// The beam's signal: column and unit (strain or m per unit), and what it measures.
    pub beam: (String, f64),
    /// What the beam's column measures.
    pub sensor: BeamSensor,
    /// Mid-span strain, if logged: column and unit.
    pub mid_strain: Option<(String, f64)>,
}

impl Default for Columns {
    /// The project's own log format: `t_s,torque_nm,theta_rad,root_strain[,mid_strain]`.
    fn default() -> Self {
        Self {
            t: ("t_s".into(), 1.0),
            torque: ("torque_nm".into(), 1.0),
            theta: ("theta_rad".into(), 1.0),
            beam: ("root_strain".into(), 1.0),
            sensor: BeamSensor::RootStrain,
            mid_strain: Some(("mid_strain".into(), 1.0)),
        }
    }
}

impl Columns {
    /// The defaults with some quantities mapped, from `t=time_ms:ms,theta=hub:deg,...`:
    /// quantities `t`, `torque`, `theta`, `strain` (root strain), `tip` (tip deflection, in
    /// place of the root strain), `mid`; units `s`, `ms`, `us` (time), `nm`, `mnm`
    /// (torque), `rad`, `deg` (angle), `strain`, `ue` (strain), `m`, `mm` (deflection),
    /// each with a leading `-` for a column that reads with the other sign (`torque=tau:-nm`).
    /// A log has one beam signal: `strain` and `tip` together are refused.
    pub fn parse(spec: &str) -> Result<Self, String> {
        let mut c = Columns::default();
        let (mut strain_given, mut tip_given) = (false, false);
        for item in spec.split(',').map(str::trim).filter(|i| !i.is_empty()) {
            let (what, rest) = item
                .split_once('=')
                .ok_or_else(|| format!("`{item}`: expected QUANTITY=COLUMN[:UNIT]"))?;
            let (column, unit) = match rest.split_once(':') {
                Some((c, u)) => (c.trim(), Some(u.trim())),
                None => (rest.trim(), None),
            };
            if column.is_empty() {
                return Err(format!("`{item}`: no column name"));
            }
            // A unit with a leading `-` reads the column with the other sign (a sensor or
            // an amplifier wired the other way round).
            let scale = |units: &[(&str, f64)]| -> Result<f64, String> {
                match unit {
                    None => Ok(units[0].1),
                    Some(u) => {
                        let (sign, name) = match u.strip_prefix('-') {
                            Some(rest) => (-1.0, rest.trim()),
                            None => (1.0, u),
                        };
                        units
                            .iter()
                            .find(|(n, _)| *n == name)
                            .map(|(_, s)| sign * *s)
                            .ok_or_else(|| {
                                let names: Vec<&str> = units.iter().map(|(n, _)| *n).collect();
                                format!(
                                    "`{item}`: unit `{u}` is not one of {} (a leading - flips the sign)",
                                    names.join(", ")
                                )
                            })
                    }
                }
            };
            let column = column.to_string();
            match what.trim() {
                "t" => c.t = (column, scale(&[("s", 1.0), ("ms", 1e-3), ("us", 1e-6)])?),
                "torque" => c.torque = (column, scale(&[("nm", 1.0), ("mnm", 1e-3)])?),
                "theta" => {
                    c.theta = (
                        column,
                        scale(&[("rad", 1.0), ("deg", core::f64::consts::PI / 180.0)])?,
                    )
                }
                "strain" => {
                    strain_given = true;
                    c.beam = (column, scale(&[("strain", 1.0), ("ue", 1e-6)])?);
                    c.sensor = BeamSensor::RootStrain;
                }
                "tip" => {
                    tip_given = true;
                    c.beam = (column, scale(&[("m", 1.0), ("mm", 1e-3)])?);
                    c.sensor = BeamSensor::TipDeflection;
                }
                "mid" => c.mid_strain = Some((column, scale(&[("strain", 1.0), ("ue", 1e-6)])?)),
                other => {
                    return Err(format!(
                        "`{other}` is not a quantity: t, torque, theta, strain, tip or mid"
                    ))
                }
            }
        }
        if strain_given && tip_given {
            return Err(
                "`strain` and `tip` both given: the calibration fits one beam signal; map the one to fit"
                    .into(),
            );
        }
        Ok(c)
    }
}

/// Reads a log CSV: a header naming at least `t_s,torque_nm,theta_rad,root_strain` (and
/// optionally `mid_strain`; other columns are ignored), then one row per sample. Errors name
/// the file, the line and the column.
pub fn read_log(text: &str, file: &str) -> Result<Log, LogError> {
    read_log_with(text, file, &Columns::default())
}

/// [`read_log`] with the columns and units of `columns`.
pub fn read_log_with(text: &str, file: &str, columns: &Columns) -> Result<Log, LogError> {
    let err = |line, problem| LogError {
        file: file.to_string(),
        line,
        problem,
    };
    let mut lines = text
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty());
    let (_, header) = lines.next().ok_or(err(None, LogProblem::Empty))?;
    let names: Vec<&str> = header.split(',').map(str::trim).collect();
    let col = |name: &str| names.iter().position(|n| *n == name);
    let need = |name: &str| {
        col(name).ok_or_else(|| {
            err(
                Some(1),
                LogProblem::MissingColumn {
                    column: name.to_string(),
                    header: header.to_string(),
                },
            )
        })
    };
    let (it, iu, ith, ie) = (
        need(&columns.t.0)?,
        need(&columns.torque.0)?,
        need(&columns.theta.0)?,
        need(&columns.beam.0)?,
    );
    let im = columns.mid_strain.as_ref().and_then(|(name, _)| col(name));
    let unit_mid = columns.mid_strain.as_ref().map_or(1.0, |m| m.1);
    let mut log = Log {
        t: vec![],
        torque: vec![],
        theta: vec![],
        beam_signal: vec![],
        sensor: columns.sensor,
        mid_strain: im.map(|_| vec![]),
    };
    for (n, line) in lines {
        let fields: Vec<&str> = line.split(',').map(str::trim).collect();
        let at = |problem| err(Some(n + 1), problem);
        if fields.len() != names.len() {
            return Err(at(LogProblem::FieldCount {
                got: fields.len(),
                header: names.len(),
            }));
        }
        let num = |i: usize| -> Result<f64, LogError> {
            let v: f64 = fields[i].parse().map_err(|_| {
                at(LogProblem::NotANumber {
                    column: names[i].to_string(),
                    text: fields[i].to_string(),
                })
            })?;
            if v.is_finite() {
                Ok(v)
            } else {
                Err(at(LogProblem::NonFinite {
                    column: names[i].to_string(),
                    value: v,
                }))
            }
        };
        let t = num(it)? * columns.t.1;
        if let Some(&prev) = log.t.last() {
            if t <= prev {
                return Err(at(LogProblem::TimeNotIncreasing(t)));
            }
        }
        log.t.push(t);
        log.torque.push(num(iu)? * columns.torque.1);
        log.theta.push(num(ith)? * columns.theta.1);
        log.beam_signal.push(num(ie)? * columns.beam.1);
        if let (Some(i), Some(m)) = (im, log.mid_strain.as_mut()) {
            m.push(num(i)? * unit_mid);
        }
    }
    if log.t.len() < 100 {
        return Err(err(None, LogProblem::TooShort(log.t.len())));
    }
    let dt = log.t[1] - log.t[0];
    if let Some(k) = log
        .t
        .windows(2)
        .position(|w| ((w[1] - w[0]) - dt).abs() > 1e-3 * dt)
    {
        return Err(err(Some(k + 3), LogProblem::NonUniform));
    }
    Ok(log)
}

impl Log {
    /// The samples logged from `from_s` to `to_s` (s on the log's own clock, either end
    /// open), or why too few remain.
    pub fn between(&self, from_s: Option<f64>, to_s: Option<f64>) -> Result<Log, LogProblem> {
        let keep = |t: f64| from_s.is_none_or(|f| t >= f) && to_s.is_none_or(|e| t <= e);
        let pick = |v: &[f64]| -> Vec<f64> {
            v.iter()
                .zip(&self.t)
                .filter(|(_, &t)| keep(t))
                .map(|(x, _)| *x)
                .collect()
        };
        let log = Log {
            t: pick(&self.t),
            torque: pick(&self.torque),
            theta: pick(&self.theta),
            beam_signal: pick(&self.beam_signal),
            sensor: self.sensor,
            mid_strain: self.mid_strain.as_deref().map(pick),
        };
        if log.t.len() < 100 {
            return Err(LogProblem::TooShort(log.t.len()));
        }
        Ok(log)
    }

    /// The log with its beam signal (and mid-span strain) taken `delay_s` later (linearly
    /// between samples): what a sensor that lags the hub by `delay_s` would
    /// have read without the lag. The last `delay_s` of the log, which has no reading to
    /// take, is dropped.
    pub fn strain_advanced(&self, delay_s: f64) -> Log {
        let dt = self.t[1] - self.t[0];
        let shift = (delay_s / dt).max(0.0);
        let n = self.t.len().saturating_sub(shift.floor() as usize + 1);
        let shifted = |v: &[f64]| {
            let mut s = lagged(v, -shift);
            s.truncate(n);
            s
        };
        Log {
            beam_signal: shifted(&self.beam_signal),
            mid_strain: self.mid_strain.as_deref().map(shifted),
            ..self.slice(0..n)
        }
    }

    /// The samples `range` (indices).
    pub fn slice(&self, range: std::ops::Range<usize>) -> Log {
        Log {
            t: self.t[range.clone()].to_vec(),
            torque: self.torque[range.clone()].to_vec(),
            theta: self.theta[range.clone()].to_vec(),
            beam_signal: self.beam_signal[range.clone()].to_vec(),
            sensor: self.sensor,
            mid_strain: self.mid_strain.as_ref().map(|m| m[range].to_vec()),
        }
    }

    /// A mid-span column that reads zero throughout is a gauge that was not fitted (or not
    /// wired): it is dropped, not fitted as a measured zero. True if it was.
    pub fn drop_unmeasured_mid(&mut self) -> bool {
        if self
            .mid_strain
            .as_ref()
            .is_some_and(|m| m.iter().all(|&x| x == 0.0))
        {
            self.mid_strain = None;
            return true;
        }
        false
    }
}

/// `v` read `samples` later (linearly between samples; before the first, the first: the
/// beam at rest), as a sensor that lags by that much reads it.
pub fn lagged(v: &[f64], samples: f64) -> Vec<f64> {
    if samples == 0.0 {
        return v.to_vec();
    }
    let last = v.len().saturating_sub(1) as f64;
    (0..v.len())
        .map(|k| {
            let x = (k as f64 - samples).clamp(0.0, last);
            let i = x.floor() as usize;
            let f = x - i as f64;
            match v.get(i + 1) {
                Some(next) => v[i] + f * (next - v[i]),
                None => v[i],
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `n` rows at 1 kHz of `t_ms,tau,hub_deg,gauge_ue`, the hub at `k` deg on row `k`.
    fn mapped_log(n: usize) -> String {
        let mut text = String::from("t_ms,tau,hub_deg,gauge_ue,other\n");
        for k in 0..n {
            text += &format!("{k},0.5,{k},{},x\n", 2 * k);
        }
        text
    }

    #[test]
    fn mapped_columns_are_read_in_si_units() {
        let columns =
            Columns::parse("t=t_ms:ms, torque=tau, theta=hub_deg:deg, strain=gauge_ue:ue").unwrap();
        let log = read_log_with(&mapped_log(200), "f.csv", &columns).unwrap();
        assert_eq!(log.t.len(), 200);
        assert!((log.t[199] - 0.199).abs() < 1e-15);
        assert!((log.theta[90] - core::f64::consts::FRAC_PI_2).abs() < 1e-15);
        assert!((log.beam_signal[100] - 200e-6).abs() < 1e-18);
        assert_eq!(log.torque[0], 0.5);
        assert_eq!(log.sensor, BeamSensor::RootStrain);
        // Not mapped and not in the header: no mid-span strain.
        assert_eq!(log.mid_strain, None);
    }

    #[test]
    fn errors_name_the_file_the_line_and_the_column() {
        let columns =
            Columns::parse("t=t_ms:ms,torque=tau,theta=hub_deg:deg,strain=gauge_ue:ue").unwrap();
        let text = mapped_log(200).replacen("0,0.5,0,0,x", "0,0.5,zero,0,x", 1);
        let e = read_log_with(&text, "f.csv", &columns).unwrap_err();
        assert_eq!(
            e.to_string(),
            "f.csv: line 2: column `hub_deg`: `zero` is not a number"
        );
        let e = read_log(&mapped_log(200), "g.csv").unwrap_err();
        assert!(
            matches!(&e.problem, LogProblem::MissingColumn { column, .. } if column == "t_s"),
            "{e}"
        );
        let short = read_log_with(&mapped_log(99), "f.csv", &columns).unwrap_err();
        assert!(matches!(short.problem, LogProblem::TooShort(99)), "{short}");
        // Row 150 (line 152: the header is line 1) comes 2 ms after the one before it.
        let mut gap = String::from("t_ms,tau,hub_deg,gauge_ue\n");
        for k in 0..200 {
            gap += &format!("{},0,0,0\n", k + usize::from(k >= 150));
        }
        let gap = read_log_with(&gap, "f.csv", &columns).unwrap_err();
        assert_eq!(gap.line, Some(152), "{gap}");
        assert!(matches!(gap.problem, LogProblem::NonUniform), "{gap}");
    }

    #[test]
    fn a_log_has_one_beam_signal_and_known_units() {
        assert!(Columns::parse("strain=a,tip=b").is_err());
        assert!(Columns::parse("theta=hub:grad")
            .unwrap_err()
            .contains("rad, deg"));
        assert!(Columns::parse("speed=w").is_err());
        let tip = Columns::parse("tip=arm:mm").unwrap();
        assert_eq!((tip.sensor, tip.beam.1), (BeamSensor::TipDeflection, 1e-3));
        // A leading `-` reads a column wired the other way round.
        let flipped = Columns::parse("torque=tau:-mnm,theta=hub:-deg").unwrap();
        assert_eq!(flipped.torque.1, -1e-3);
        assert_eq!(flipped.theta.1, -core::f64::consts::PI / 180.0);
        assert!(Columns::parse("t=time:-").is_err());
    }

    #[test]
    fn a_lag_is_read_back_between_samples() {
        let ramp: Vec<f64> = (0..10).map(f64::from).collect();
        let late = lagged(&ramp, 1.5);
        // A sensor 1.5 samples late reads the ramp 1.5 lower, and the first sample before it.
        assert_eq!(&late[2..], &[0.5, 1.5, 2.5, 3.5, 4.5, 5.5, 6.5, 7.5]);
        assert_eq!(&late[..2], &[0.0, 0.0]);
        assert_eq!(lagged(&ramp, 0.0), ramp);
    }
}
