//! Motor-drive firmware, minimal bring-up: builds the controller from compiled-in constants
//! and runs the control step from the SysTick exception at 1 kHz.
//!
//! This is the placeholder the board-support issue fills in (real encoder timer, bridge ADC,
//! PWM and fault pin). It already links the whole control core for the Cortex-M4F so that the
//! build, the flash size and the no-panic discipline are checked from the first commit. With no
//! sensors wired yet, the raw measurement stays at rest and the drive never leaves `Idle`.
#![cfg_attr(target_os = "none", no_std, no_main)]

#[cfg(target_os = "none")]
mod drive {
    use core::cell::RefCell;
    use cortex_m::interrupt::Mutex;
    use cortex_m::peripheral::syst::SystClkSource;
    use cortex_m_rt::{entry, exception};
    use model_core::gains::{schedule, GAIN_TABLE};
    use model_core::{
        Beam, BeamParams, ControlLaw, Controller, ControllerSettings, ModalModel, RawMeasurement,
        Spline,
    };
    use panic_halt as _;

    /// Core clock after reset (HSI), Hz; the board issue raises it to 168 MHz.
    const CORE_HZ: u32 = 16_000_000;
    /// Control rate, Hz.
    const LOOP_HZ: u32 = 1_000;
    /// The payload this drive carries, kg: picks the gains from the compiled gain table.
    const PAYLOAD_KG: f32 = 0.0;

    static CONTROLLER: Mutex<RefCell<Option<Controller<2>>>> = Mutex::new(RefCell::new(None));

    /// Builds the controller; `None` if the compiled-in configuration is invalid.
    fn build_controller() -> Option<Controller<2>> {
        let params = BeamParams {
            tip_mass_kg: PAYLOAD_KG as f64,
            ..BeamParams::aluminium()
        };
        let model = ModalModel::<3>::try_build(&Beam::try_build(params).ok()?).ok()?;
        // Gains from gains.toml, validated by the build and scheduled on the payload here.
        let law = ControlLaw::try_build(schedule(GAIN_TABLE, "smc", PAYLOAD_KG)?, &model).ok()?;
        let half_pi = core::f32::consts::FRAC_PI_2;
        let spline = Spline::quintic(-half_pi, half_pi, 0.35).ok()?;
        Controller::try_build(ControllerSettings::default(), law, spline).ok()
    }

    #[entry]
    fn main() -> ! {
        let mut cp = cortex_m::Peripherals::take().unwrap_or_else(|| loop {
            cortex_m::asm::wfi();
        });
        let controller = build_controller();
        cortex_m::interrupt::free(|cs| CONTROLLER.borrow(cs).replace(controller));
        cp.SYST.set_clock_source(SystClkSource::Core);
        cp.SYST.set_reload(CORE_HZ / LOOP_HZ - 1);
        cp.SYST.clear_current();
        cp.SYST.enable_counter();
        cp.SYST.enable_interrupt();
        loop {
            cortex_m::asm::wfi();
        }
    }

    #[exception]
    fn SysTick() {
        cortex_m::interrupt::free(|cs| {
            if let Some(c) = CONTROLLER.borrow(cs).borrow_mut().as_mut() {
                let out = c.step(&RawMeasurement::default());
                // No amplifier yet: the command is computed and dropped.
                core::hint::black_box(out.torque_nm);
            }
        });
    }
}

/// On the host this crate is only type-checked; the firmware is built with `cargo fw`.
#[cfg(not(target_os = "none"))]
fn main() {
    eprintln!("the firmware runs on thumbv7em-none-eabihf: build it with `cargo fw`");
    std::process::exit(2);
}
