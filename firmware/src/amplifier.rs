//! The motor amplifier as a torque actuator: PWM duty for the magnitude, a direction pin for
//! the sign, an enable pin that must be high for any current to flow.
//!
//! The amplifier is a current (torque) mode drive: its current set-point is proportional to
//! the PWM duty, so torque = duty * full-scale torque. That one scaling lives in
//! [`TorqueScale`]; nothing else in the firmware converts torque to duty. Generic over
//! `embedded-hal` 1.0's [`SetDutyCycle`] and [`OutputPin`], so the board passes its timer
//! channel and GPIOs and the host tests pass mocks.

use embedded_hal::digital::OutputPin;
use embedded_hal::pwm::SetDutyCycle;
use model_core::{Mode, TorqueCommand};

/// Torque at 100 % duty, the amplifier's full scale.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TorqueScale {
    /// N m at full duty; positive and finite.
    pub full_scale_nm: f32,
}

/// The duty and direction for one torque.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Drive {
    /// Duty in counts of the PWM's `max_duty`.
    pub duty: u16,
    /// True for positive torque (the direction pin high).
    pub positive: bool,
}

impl TorqueScale {
    /// The duty (in `max_duty` counts, rounded to nearest) and direction for `torque_nm`.
    /// Torques past full scale saturate; a non-finite torque gives zero duty.
    pub fn duty(&self, torque_nm: f32, max_duty: u16) -> Drive {
        let fraction = if torque_nm.is_finite() && self.full_scale_nm > 0.0 {
            (libm::fabsf(torque_nm) / self.full_scale_nm).min(1.0)
        } else {
            0.0
        };
        Drive {
            duty: libm::roundf(fraction * max_duty as f32) as u16,
            positive: torque_nm >= 0.0,
        }
    }
}

/// Which of the amplifier's signals failed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Error<P, D, E> {
    /// Setting the PWM duty failed.
    Pwm(P),
    /// Setting the direction pin failed.
    Direction(D),
    /// Setting the enable pin failed.
    Enable(E),
}

/// The amplifier's three inputs.
#[derive(Debug)]
pub struct Amplifier<PWM, DIR, EN> {
    pwm: PWM,
    dir: DIR,
    en: EN,
    scale: TorqueScale,
}

/// The error type of an [`Amplifier`] over these pins.
pub type AmpError<PWM, DIR, EN> = Error<
    <PWM as embedded_hal::pwm::ErrorType>::Error,
    <DIR as embedded_hal::digital::ErrorType>::Error,
    <EN as embedded_hal::digital::ErrorType>::Error,
>;

impl<PWM: SetDutyCycle, DIR: OutputPin, EN: OutputPin> Amplifier<PWM, DIR, EN> {
    /// Takes the signals and puts the amplifier in its safe state (disabled, zero duty).
    pub fn new(
        pwm: PWM,
        dir: DIR,
        en: EN,
        scale: TorqueScale,
    ) -> Result<Self, AmpError<PWM, DIR, EN>> {
        let mut amp = Self {
            pwm,
            dir,
            en,
            scale,
        };
        amp.disable()?;
        Ok(amp)
    }

    /// Enable low first (the amplifier stops at once), then zero duty.
    pub fn disable(&mut self) -> Result<(), AmpError<PWM, DIR, EN>> {
        let en = self.en.set_low().map_err(Error::Enable);
        let pwm = self.pwm.set_duty_cycle(0).map_err(Error::Pwm);
        en.and(pwm)
    }

    /// Applies one tick's command: torque while slewing or holding, disabled otherwise.
    pub fn apply(&mut self, cmd: &TorqueCommand) -> Result<(), AmpError<PWM, DIR, EN>> {
        if !matches!(cmd.mode, Mode::Slewing | Mode::Holding) {
            return self.disable();
        }
        let d = self.scale.duty(cmd.torque_nm, self.pwm.max_duty_cycle());
        // Direction before duty, duty before enable: no instant drives the old duty the
        // new way round.
        self.dir
            .set_state(d.positive.into())
            .map_err(Error::Direction)?;
        self.pwm.set_duty_cycle(d.duty).map_err(Error::Pwm)?;
        self.en.set_high().map_err(Error::Enable)
    }

    /// The torque scaling.
    pub fn scale(&self) -> TorqueScale {
        self.scale
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use embedded_hal_mock::eh1::digital::{Mock as PinMock, State, Transaction as Pin};
    use embedded_hal_mock::eh1::pwm::{Mock as PwmMock, Transaction as Pwm};
    use embedded_hal_mock::eh1::MockError;
    use model_core::FaultFlags;

    const SCALE: TorqueScale = TorqueScale {
        full_scale_nm: 10.0,
    };

    fn command(mode: Mode, torque_nm: f32) -> TorqueCommand {
        TorqueCommand {
            torque_nm,
            mode,
            ..Default::default()
        }
    }

    #[test]
    fn duty_is_proportional_saturates_and_rejects_non_finite() {
        let d = |t| SCALE.duty(t, 4200);
        assert_eq!(
            d(5.0),
            Drive {
                duty: 2100,
                positive: true
            }
        );
        assert_eq!(
            d(-2.5),
            Drive {
                duty: 1050,
                positive: false
            }
        );
        assert_eq!(d(25.0).duty, 4200);
        assert_eq!(
            d(-25.0),
            Drive {
                duty: 4200,
                positive: false
            }
        );
        assert_eq!(d(f32::NAN).duty, 0);
        assert_eq!(d(f32::INFINITY).duty, 0);
        // One LSB of duty is 10/4200 N m; half of one rounds up.
        assert_eq!(d(10.0 / 4200.0 * 0.5).duty, 1);
    }

    #[test]
    fn new_starts_disabled_and_torque_sets_direction_duty_then_enable() {
        let mut pwm = PwmMock::new(&[
            Pwm::set_duty_cycle(0),
            Pwm::max_duty_cycle(4200),
            Pwm::set_duty_cycle(1260),
            Pwm::max_duty_cycle(4200),
            Pwm::set_duty_cycle(4200),
            Pwm::set_duty_cycle(0),
        ]);
        let mut dir = PinMock::new(&[Pin::set(State::Low), Pin::set(State::High)]);
        let mut en = PinMock::new(&[
            Pin::set(State::Low),
            Pin::set(State::High),
            Pin::set(State::High),
            Pin::set(State::Low),
        ]);
        let mut amp = Amplifier::new(pwm.clone(), dir.clone(), en.clone(), SCALE).unwrap();
        amp.apply(&command(Mode::Slewing, -3.0)).unwrap();
        amp.apply(&command(Mode::Holding, 12.0)).unwrap();
        amp.apply(&TorqueCommand {
            faults: FaultFlags::AMP_FAULT,
            ..command(Mode::Fault, 0.0)
        })
        .unwrap();
        pwm.done();
        dir.done();
        en.done();
    }

    #[test]
    fn idle_never_enables_even_with_a_torque() {
        let mut pwm = PwmMock::new(&[Pwm::set_duty_cycle(0), Pwm::set_duty_cycle(0)]);
        let mut dir = PinMock::new(&[]);
        let mut en = PinMock::new(&[Pin::set(State::Low), Pin::set(State::Low)]);
        let mut amp = Amplifier::new(pwm.clone(), dir.clone(), en.clone(), SCALE).unwrap();
        amp.apply(&command(Mode::Idle, 3.0)).unwrap();
        pwm.done();
        dir.done();
        en.done();
    }

    #[test]
    fn a_failing_enable_pin_still_zeroes_the_duty_and_is_reported() {
        let err = MockError::Io(std::io::ErrorKind::Other);
        let mut pwm = PwmMock::new(&[Pwm::set_duty_cycle(0)]);
        let mut dir = PinMock::new(&[]);
        let mut en = PinMock::new(&[Pin::set(State::Low).with_error(err.clone())]);
        let result = Amplifier::new(pwm.clone(), dir.clone(), en.clone(), SCALE);
        assert!(matches!(result, Err(Error::Enable(_))));
        pwm.done();
        dir.done();
        en.done();
    }
}
