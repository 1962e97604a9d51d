//! The model against a log (`beam replay`): the beam driven by the logged hub angle (the hub
//! prescribed, so torque and motor errors cannot leak into the flexible part) and, for the
//! hub itself, by the logged torque open loop; with the figures that say how well the model
//! explains the log.

use crate::identify::calibrate::{replay as replay_torque, BeamSensor, Log, Windows};
use crate::io::params_file::Sensors;
use model_core::{BeamParams, ModalModel};
use serde::Serialize;

pub use super::hub::*;
pub use super::prescribed::*;

/// How well a model explains a log.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ReplayReport {
    /// RMS hub-angle error of the open-loop torque replay over the move and settling, deg.
    pub hub_rms_err_deg: f64,
    /// What the log measures the beam with: `root strain` or `tip deflection`.
    pub beam_signal: &'static str,
    /// The unit of the two figures below: `ue` (root strain) or `mm` (tip deflection).
    pub beam_unit: &'static str,
    /// RMS error of the beam's signal with the hub prescribed, over the move and settling.
    pub beam_rms_err: f64,
    /// RMS of the measured signal over the same window (the error's yardstick).
    pub beam_rms_measured: f64,
    /// The error as a fraction of the measured RMS.
    pub beam_rel_err: f64,
    /// The first vibration frequency in the logged beam signal from the end of the move to
    /// the end of the log, Hz.
    pub freq_log_hz: Option<f64>,
    /// The same from the model's (hub prescribed), Hz.
    pub freq_model_hz: Option<f64>,
    /// Why a frequency is missing, if one is: the window after the move too short to hold
    /// two cycles of the vibration, or no vibration in it.
    pub freq_note: Option<String>,
}

/// Why [`vibration_hz`] finds no frequency.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum NoFrequency {
    /// Nothing but a line (no vibration).
    Flat,
    /// The signal fits best with fewer than two cycles in the window: its frequency cannot
    /// be told from the window's length (a longer log after the move can).
    WindowTooShort,
}

/// The vibration frequency of `signal` over `[from, to]` s (times `t`): the undamped
/// frequency of the damped sinusoid plus line that fits it best
/// ([`crate::identify::ringing::ringing`], which calibration holds its model to; a mode
/// slower than two cycles of the window is not seen, and the caller must not ask for one:
/// [`replay_report`] checks the window against the model's first mode).
/// [`NoFrequency::WindowTooShort`] when the window holds too few samples or too little time
/// for any frequency, [`NoFrequency::Flat`] when the signal does not ring in it.
pub fn vibration_hz(t: &[f64], signal: &[f64], from: f64, to: f64) -> Result<f64, NoFrequency> {
    use crate::identify::ringing::{ringing, NoRinging};
    ringing(t, signal, from, to)
        .map(|r| r.hz)
        .map_err(|e| match e {
            NoRinging::TooShort => NoFrequency::WindowTooShort,
            NoRinging::Flat => NoFrequency::Flat,
        })
}

/// `log` as the model sees it through the rig's `sensors`: the torque the hub received and
/// the strain the beam's curvature implies.
pub fn corrected(log: &Log, sensors: &Sensors) -> Log {
    let mut log = log.clone();
    log.torque
        .iter_mut()
        .for_each(|u| *u = sensors.applied_torque(*u));
    log.beam_signal
        .iter_mut()
        .for_each(|e| *e /= sensors.gauge_scale);
    log
}

/// The model against a log, sample by sample: what `beam replay --csv` writes and the
/// calibration figures draw. Model strains are as the log's gauge would read them.
#[derive(Clone, Debug, PartialEq)]
pub struct Traces {
    /// Time from the log's first sample, s.
    pub t: Vec<f64>,
    /// Logged hub angle, rad.
    pub theta_log: Vec<f64>,
    /// Hub angle of the torque replayed open loop through the sensors, rad.
    pub theta_model: Vec<f64>,
    /// Hub rate from the logged angle (the prescribed hub's), rad/s.
    pub omega_log: Vec<f64>,
    /// Hub rate of the torque replay (central differences), rad/s.
    pub omega_model: Vec<f64>,
    /// What the log measures the beam with.
    pub sensor: BeamSensor,
    /// The logged beam signal (root strain or tip deflection, SI).
    pub beam_log: Vec<f64>,
    /// The same of the beam on the prescribed hub.
    pub beam_model: Vec<f64>,
    /// Logged mid-span strain and the model's (hub prescribed), where the log has it.
    pub mid: Option<(Vec<f64>, Vec<f64>)>,
}

/// The model of `params` against the whole of `log`, read through `sensors`; `None` if the
/// model breaks down.
pub fn traces<const N: usize>(params: &BeamParams, sensors: &Sensors, log: &Log) -> Option<Traces> {
    let t: Vec<f64> = log.t.iter().map(|x| x - log.t[0]).collect();
    let t_end = t[t.len() - 1];
    let (th, _) = replay_torque::<N>(params, &corrected(log, sensors), t_end)?;
    let n = th.len().min(t.len());
    let hub = HubMotion::of(log, hub_window_s(params));
    let pr = prescribed::<N>(params, log, &hub)?;
    let dt = t[1] - t[0];
    let omega_model = (0..n)
        .map(|k| {
            let (a, b) = (k.saturating_sub(1), (k + 1).min(n - 1));
            if b > a {
                (th[b] - th[a]) / ((b - a) as f64 * dt)
            } else {
                0.0
            }
        })
        .collect();
    let g = sensors.gauge_scale;
    Some(Traces {
        t: t[..n].to_vec(),
        theta_log: log.theta[..n].to_vec(),
        theta_model: th,
        omega_log: hub.omega[..n].to_vec(),
        omega_model,
        sensor: log.sensor,
        beam_log: log.beam_signal[..n].to_vec(),
        beam_model: pr.beam_signal[..n].iter().map(|e| e * g).collect(),
        mid: log
            .mid_strain
            .as_ref()
            .map(|m| (m[..n].to_vec(), pr.mid_strain[..n].to_vec())),
    })
}

impl Traces {
    /// As CSV: `t_s, theta_log_rad, theta_model_rad, omega_log_rad_s, omega_model_rad_s,
    /// root_strain_log, root_strain_model[, mid_strain_log, mid_strain_model]` (for a tip
    /// sensor's log `tip_m_log, tip_m_model` in place of the root strain's).
    pub fn write_csv(&self, w: &mut dyn std::io::Write) -> std::io::Result<()> {
        let beam = match self.sensor {
            BeamSensor::RootStrain => "root_strain",
            BeamSensor::TipDeflection => "tip_m",
        };
        write!(
            w,
            "t_s,theta_log_rad,theta_model_rad,omega_log_rad_s,omega_model_rad_s,{beam}_log,{beam}_model"
        )?;
        if self.mid.is_some() {
            write!(w, ",mid_strain_log,mid_strain_model")?;
        }
        writeln!(w)?;
        for k in 0..self.t.len() {
            write!(
                w,
                "{},{},{},{},{},{},{}",
                self.t[k],
                self.theta_log[k],
                self.theta_model[k],
                self.omega_log[k],
                self.omega_model[k],
                self.beam_log[k],
                self.beam_model[k]
            )?;
            if let Some((l, m)) = &self.mid {
                write!(w, ",{},{}", l[k], m[k])?;
            }
            writeln!(w)?;
        }
        Ok(())
    }

    /// The paper's calibration figures: hub angle, hub rate, root strain and (where logged)
    /// mid-span strain, measured against the model, to `path` (.png or .svg).
    pub fn plot(
        &self,
        title: &str,
        path: &std::path::Path,
    ) -> Result<(), crate::io::plot::PlotError> {
        let pts = |v: &[f64], scale: f64| -> Vec<(f64, f64)> {
            self.t.iter().zip(v).map(|(t, y)| (*t, y * scale)).collect()
        };
        let deg = 180.0 / core::f64::consts::PI;
        let mut panels = vec![
            (
                "Hub angle (model: logged torque, open loop)",
                "deg",
                vec![
                    ("log", pts(&self.theta_log, deg)),
                    ("model", pts(&self.theta_model, deg)),
                ],
            ),
            (
                "Hub rate (log: quadratic fit to the angle; model: torque replay)",
                "deg/s",
                vec![
                    ("log", pts(&self.omega_log, deg)),
                    ("model", pts(&self.omega_model, deg)),
                ],
            ),
            (
                match self.sensor {
                    BeamSensor::RootStrain => "Root strain (model: logged hub angle)",
                    BeamSensor::TipDeflection => "Tip deflection (model: logged hub angle)",
                },
                match self.sensor {
                    BeamSensor::RootStrain => "microstrain",
                    BeamSensor::TipDeflection => "mm",
                },
                vec![
                    ("log", pts(&self.beam_log, self.sensor.display_scale())),
                    ("model", pts(&self.beam_model, self.sensor.display_scale())),
                ],
            ),
        ];
        if let Some((l, m)) = &self.mid {
            panels.push((
                "Mid-span strain (model: logged hub angle)",
                "microstrain",
                vec![("log", pts(l, 1e6)), ("model", pts(m, 1e6))],
            ));
        }
        crate::io::plot::plot_panels(title, panels, path)
    }
}

/// The model of `params`, read through the rig's `sensors`, against `log` over `windows`.
pub fn replay_report<const N: usize>(
    params: &BeamParams,
    sensors: &Sensors,
    log: &Log,
    windows: &Windows,
) -> Option<ReplayReport> {
    let t: Vec<f64> = log.t.iter().map(|x| x - log.t[0]).collect();
    let t_last = t[t.len() - 1];
    let (th, _) = replay_torque::<N>(params, &corrected(log, sensors), windows.settle_end_s)?;
    let eps: Vec<f64> = replay_prescribed::<N>(params, log)?
        .into_iter()
        .map(|e| e * sensors.gauge_scale)
        .collect();
    let in_window =
        |k: usize| t[k] >= windows.start_s - 1e-9 && t[k] <= windows.settle_end_s + 1e-9;
    // The search sees only modes above two cycles of the window; a window shorter than two
    // periods of the model's first clamped mode (the slowest the beam rings at after a move)
    // would report another frequency than the mode's (a 3.4 Hz mode in 0.4 s read 6.2-6.7 Hz).
    let first_hz = ModalModel::<N>::try_build(&model_core::Beam::try_build(*params).ok()?)
        .ok()?
        .clamped_hz[0];
    let short = t_last - windows.end_s < 2.0 / first_hz;
    let freq = |signal: &[f64]| {
        if short {
            Err(NoFrequency::WindowTooShort)
        } else {
            vibration_hz(&t, signal, windows.end_s, t_last)
        }
    };
    let (freq_log, freq_model) = (freq(&log.beam_signal), freq(&eps));
    let unit = log.sensor.display_scale();
    let (mut se, mut ss, mut sm, mut n) = (0.0, 0.0, 0.0, 0usize);
    for k in 0..th.len().min(eps.len()) {
        if in_window(k) {
            se += (th[k] - log.theta[k]).powi(2);
            ss += ((eps[k] - log.beam_signal[k]) * unit).powi(2);
            sm += (log.beam_signal[k] * unit).powi(2);
            n += 1;
        }
    }
    let n = n.max(1) as f64;
    let (strain_err, strain_rms) = ((ss / n).sqrt(), (sm / n).sqrt());
    Some(ReplayReport {
        hub_rms_err_deg: (se / n).sqrt().to_degrees(),
        beam_signal: log.sensor.name(),
        beam_unit: log.sensor.unit(),
        beam_rms_err: strain_err,
        beam_rms_measured: strain_rms,
        beam_rel_err: strain_err / strain_rms.max(1e-12),
        freq_log_hz: freq_log.ok(),
        freq_model_hz: freq_model.ok(),
        freq_note: match (freq_log, freq_model) {
            (Err(NoFrequency::WindowTooShort), _) | (_, Err(NoFrequency::WindowTooShort)) => {
                Some(format!(
                    "window too short: the {:.3} s after the move hold under two cycles of the vibration",
                    t_last - windows.end_s
                ))
            }
            (Err(NoFrequency::Flat), _) | (_, Err(NoFrequency::Flat)) => {
                Some("no vibration after the move".into())
            }
            _ => None,
        },
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A smooth slew of 0.3 rad over 1 s at 500 Hz, its angle quantised to `step` (if any).
    fn slew_log(step: Option<f64>) -> Log {
        let t: Vec<f64> = (0..750).map(|k| k as f64 * 0.002).collect();
        let theta = t
            .iter()
            .map(|&t| {
                let x = t.min(1.0);
                let th = 0.3
                    * (x - (2.0 * std::f64::consts::PI * x).sin() / (2.0 * std::f64::consts::PI));
                step.map_or(th, |q| q * (th / q).round())
            })
            .collect();
        Log {
            torque: vec![0.0; t.len()],
            beam_signal: vec![0.0; t.len()],
            sensor: BeamSensor::RootStrain,
            mid_strain: None,
            theta,
            t,
        }
    }

    #[test]
    fn a_gauges_lag_is_found_and_taken_back_out() {
        // The strain of a beam 10 % stiffer than the model, on the slew's hub, logged 40 ms
        // late (20 samples at 500 Hz).
        let model = BeamParams::aluminium();
        let truth = BeamParams {
            ei_nm2: model.ei_nm2 * 1.1,
            ..model
        };
        let mut log = slew_log(None);
        let strain = replay_prescribed::<3>(&truth, &log).unwrap();
        let lag = 20;
        log.beam_signal = (0..strain.len())
            .map(|k| strain[k.saturating_sub(lag)])
            .collect();
        // On the beam's own model, to within a millisecond; on the model a tenth off, this
        // slow 1 s slew's strain drifts in phase over the move and pulls the peak early
        // (by 7 ms here; `calibrate` finds it again on its result).
        let found = strain_delay::<3>(&truth, &log).unwrap();
        assert!((found - 0.040).abs() < 0.001, "{found}");
        let off = strain_delay::<3>(&model, &log).unwrap();
        eprintln!("lag found on the model a tenth off: {off}");
        assert!(off > 0.025 && off < found, "{off}");
        // Without a lag, none found (within a sample).
        let mut on_time = slew_log(None);
        on_time.beam_signal = strain.clone();
        assert!(strain_delay::<3>(&truth, &on_time).unwrap().abs() < 0.001);
        // Taken back out, the strain is the beam's again, the log shorter by the lag.
        let back = log.strain_advanced(lag as f64 * 0.002);
        assert_eq!(back.t.len(), log.t.len() - lag - 1);
        for (b, s) in back.beam_signal.iter().zip(&strain).skip(lag) {
            assert!((b - s).abs() <= 1e-12 * s.abs().max(1e-9), "{b} {s}");
        }
    }

    #[test]
    fn following_the_strain_puts_back_the_vibration_the_prescribed_hub_missed() {
        // The real hub chatters at 60 Hz for its first 0.1 s, which excites the beam; the
        // prescribed hub (the logged angle without the chatter) does not. After the chatter
        // the two hubs are the same, so what differs is the beam's state: open, the model
        // has none of that vibration; corrected by the logged strain, it has.
        let params = BeamParams::aluminium();
        let clean = slew_log(None);
        let mut chattering = clean.clone();
        for (th, t) in chattering.theta.iter_mut().zip(&clean.t) {
            if *t < 0.1 {
                *th += 2e-3 * (2.0 * std::f64::consts::PI * 60.0 * t).sin();
            }
        }
        let real_hub = HubMotion::of(&chattering, 0.004);
        let truth = prescribed::<3>(&params, &chattering, &real_hub).unwrap();
        let mut log = clean.clone();
        log.beam_signal = truth.beam_signal.clone();
        let hub = HubMotion::of(&clean, 0.004);
        let alpha_err = hub.alpha_rms_diff(&real_hub);
        let open = prescribed::<3>(&params, &log, &hub).unwrap();
        let observer = StrainObserver {
            gauge_scale: 1.0,
            alpha_err,
            strain_err: 1e-7,
        };
        let followed = prescribed_observed::<3>(&params, &log, &hub, Some(observer)).unwrap();
        // After the chatter and a settling time of the observer.
        let after: Vec<usize> = (0..clean.t.len()).filter(|&k| clean.t[k] > 0.2).collect();
        let rms = |a: &[f64], b: &[f64]| {
            (after.iter().map(|&k| (a[k] - b[k]).powi(2)).sum::<f64>() / after.len() as f64).sqrt()
        };
        let size = rms(&truth.flex_torque_nm, &vec![0.0; clean.t.len()]);
        let (e_open, e_followed) = (
            rms(&open.flex_torque_nm, &truth.flex_torque_nm),
            rms(&followed.flex_torque_nm, &truth.flex_torque_nm),
        );
        assert!(
            e_open > 0.05 * size,
            "the chatter left too little: {e_open} of {size}"
        );
        assert!(
            e_followed < 0.2 * e_open,
            "torque after the chatter: {e_followed} against {e_open} open (of {size})"
        );
    }

    #[test]
    fn the_encoder_step_is_found_on_a_quantised_angle_and_not_on_a_smooth_one() {
        let q = 2.0 * std::f64::consts::PI / 16384.0;
        let found = encoder_step(&slew_log(Some(q)).theta).unwrap();
        assert!((found / q - 1.0).abs() < 1e-9, "{found} against {q}");
        assert_eq!(encoder_step(&slew_log(None).theta), None);
        assert_eq!(encoder_step(&[0.0, q, 0.0]), None);
        // Logged in degrees to three decimals (as another rig's CSV might be), then read
        // back in radians: off the grid by up to 2.3 % of a step, and still found.
        let printed: Vec<f64> = slew_log(Some(q))
            .theta
            .iter()
            .map(|t| (t.to_degrees() * 1e3).round() / 1e3 * std::f64::consts::PI / 180.0)
            .collect();
        let found = encoder_step(&printed).unwrap();
        assert!((found / q - 1.0).abs() < 1e-3, "{found} against {q}");
    }

    #[test]
    fn requantising_keeps_the_step_moves_the_grid_and_stays_within_a_step() {
        let q = 2.0 * std::f64::consts::PI / 4096.0;
        let log = slew_log(Some(q));
        for phase in ENCODER_PHASES {
            let again = requantised(&log, 6, q, phase);
            // On the grid moved by the phase: (theta - origin) / q + phase is an integer.
            for (a, b) in again.theta.iter().zip(&log.theta) {
                let n = a / q + phase;
                assert!((n - n.round()).abs() < 1e-6, "{a} is off the moved grid");
                assert!((a - b).abs() <= 1.5 * q, "{a} is more than a step from {b}");
            }
            assert!(again.theta.iter().zip(&log.theta).any(|(a, b)| a != b));
        }
    }

    #[test]
    fn finds_the_frequency_of_a_noisy_damped_sinusoid_on_a_drifting_line() {
        // 2.7 Hz decaying at 0.5/s, on a drift, with noise a fifth of the initial amplitude
        // (a small residual read by a noisy gauge): the estimate must land within 1 %.
        let mut seed = 7u64;
        let mut noise = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed as f64 / u64::MAX as f64 - 0.5) * 2.0 * 0.2 * 3f64.sqrt() / 3.0
        };
        let t: Vec<f64> = (0..1000).map(|k| k as f64 * 0.002).collect();
        let y: Vec<f64> = t
            .iter()
            .map(|&t| {
                (-0.5 * t).exp() * (2.0 * core::f64::consts::PI * 2.7 * t + 0.3).cos()
                    + 0.4 * t
                    + noise()
            })
            .collect();
        let f = vibration_hz(&t, &y, 0.0, 2.0).unwrap();
        assert!((f - 2.7).abs() < 0.027, "{f}");
        // Flat or too short: no frequency.
        assert_eq!(
            vibration_hz(&t, &vec![1.0; 1000], 0.0, 2.0),
            Err(NoFrequency::Flat)
        );
        assert_eq!(
            vibration_hz(&t, &y, 0.0, 0.02),
            Err(NoFrequency::WindowTooShort)
        );
    }

    #[test]
    fn a_window_under_two_cycles_of_the_first_mode_is_too_short_not_another_frequency() {
        // The aluminium beam (first clamped mode 5.48 Hz, two periods 0.365 s) after a PD
        // slew: cut 0.25 s after the move's end the window holds under two of its periods,
        // and the replay says so rather than reading another frequency; 1.2 s after it, both
        // frequencies are read and agree.
        use crate::identify::calibrate::{find_windows, read_log};
        let truth = BeamParams::aluminium();
        let m = ModalModel::<3>::try_build(&model_core::Beam::try_build(truth).unwrap()).unwrap();
        let run = beam_sim::sim::simulate(
            &m,
            model_core::Law::Pd(model_core::PdGains::BASELINE),
            &beam_sim::sim::SimOptions {
                duration_s: 2.0,
                ..Default::default()
            },
        )
        .unwrap();
        let mut csv = Vec::new();
        crate::io::files::write_trace_csv(&run, &mut csv).unwrap();
        let log = read_log(std::str::from_utf8(&csv).unwrap(), "log.csv").unwrap();
        let w = find_windows(&log).unwrap();
        let upto = |s: f64| log.between(None, Some(w.end_s + s)).unwrap();
        let short = replay_report::<3>(&truth, &Sensors::default(), &upto(0.25), &w).unwrap();
        assert_eq!((short.freq_log_hz, short.freq_model_hz), (None, None));
        assert!(short.freq_note.unwrap().starts_with("window too short"));
        let long = replay_report::<3>(&truth, &Sensors::default(), &upto(1.2), &w).unwrap();
        let (fl, fm) = (long.freq_log_hz.unwrap(), long.freq_model_hz.unwrap());
        assert!((fl - fm).abs() / fl < 0.03, "{fl} vs {fm} Hz");
    }
}
