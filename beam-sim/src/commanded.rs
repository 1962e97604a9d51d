//! A commanded drive against the simulated beam: a script of wire-protocol commands, sent
//! between ticks as the board's link task would, carried out by model-core's command handler
//! on the same controller the firmware runs.

use crate::plant::{Plant, State};
use crate::sensors::{SensorConfig, SensorFault, Sensors};
use crate::sim::{settings_for, Integrator, SimError};
use beam_wire::command::{Command, Outcome, Reply, Request};
use model_core::commands::{CommandedController, Commander};
use model_core::DriveTable;
use model_core::{
    BeamParams, Controller, FaultFlags, LawKind, ModalModel, Mode, RawMeasurement, Spline,
    TorqueCommand,
};

/// One step of a script.
#[derive(Clone, Debug, PartialEq)]
pub enum Step {
    /// Send a command before the next tick.
    Send(Command),
    /// Let this many seconds of ticks pass.
    Wait(f64),
    /// Tick until the move is over (the controller holds, or is idle or faulted), then
    /// `settle_s` more; at most `max_s` in all.
    UntilDone {
        /// Ticks after the move's end, s.
        settle_s: f64,
        /// Give up after this long, s.
        max_s: f64,
    },
    /// Assert the amplifier's fault line for this many ticks.
    AmpFault(u32),
    /// Change the payload the beam really carries, kg (attached at rest: the state carries
    /// over; tell the drive with `SetPayload`).
    Attach(f64),
    /// From now on a constant external torque acts on the hub, N m (a tilted rig, a cable, a
    /// hand; 0 removes it).
    Load(f64),
    /// From now on the sensors fail as this says ([`SensorFault::None`] heals them).
    Sensor(SensorFault),
    /// From now on each command is prepared on a snapshot this many ticks before it is
    /// applied, with the ticks in between run (a board's link task, which plans while the
    /// tick goes on); 0, the default, applies it at once.
    Latency(u32),
}

/// A command, when it was sent, and the drive's answer.
#[derive(Clone, Debug, PartialEq)]
pub struct Exchange {
    /// Time of the tick it preceded, s from the start of the run.
    pub t: f64,
    /// What was sent.
    pub request: Request,
    /// What came back.
    pub reply: Reply,
}

/// One tick of a commanded run.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Tick {
    /// Time, s from the start of the run.
    pub t: f64,
    /// True hub angle, rad.
    pub theta: f64,
    /// True root strain.
    pub root_strain: f64,
    /// Torque commanded, N m (bit for bit what the controller returned).
    pub torque_nm: f32,
    /// Controller mode after the tick.
    pub mode: Mode,
    /// Faults latched after the tick.
    pub faults: FaultFlags,
}

/// What a commanded run produced.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct CommandedRun {
    /// Every tick.
    pub ticks: Vec<Tick>,
    /// Every command and its reply, in order.
    pub exchanges: Vec<Exchange>,
}

impl CommandedRun {
    /// For each accepted move (a `Moving` reply), the time its planned spline ends, s.
    pub fn move_ends(&self) -> Vec<f64> {
        self.exchanges
            .iter()
            .filter_map(|e| match e.reply.outcome {
                Outcome::Moving { duration_s } => Some(e.t + duration_s as f64),
                _ => None,
            })
            .collect()
    }

    /// The true hub angle at time `t` (the last tick at or before it), rad.
    pub fn theta_at(&self, t: f64) -> Option<f64> {
        self.ticks
            .iter()
            .rev()
            .find(|k| k.t <= t + 1e-9)
            .map(|k| k.theta)
    }

    /// Settle time of a move commanded at `from` to `target_rad`: how long after `from` the
    /// hub came within `spec`'s band of the target and the root strain within its band of
    /// zero, staying there until `until` (the next move's command, or the run's end), s.
    /// `None` if it was out of either band at `until`'s last tick.
    pub fn settle_s(
        &self,
        from: f64,
        until: f64,
        target_rad: f64,
        spec: &crate::metrics::SettleSpec,
    ) -> Option<f64> {
        let (hub, strain) = (spec.hub_deg.to_radians(), spec.strain_ue * 1e-6);
        let window: Vec<&Tick> = self
            .ticks
            .iter()
            .filter(|k| k.t >= from - 1e-9 && k.t < until - 1e-9)
            .collect();
        if window.is_empty() {
            return None;
        }
        crate::metrics::settled_from(
            &window,
            |k| k.t - from,
            |k| (k.theta - target_rad).abs() <= hub && k.root_strain.abs() <= strain,
        )
    }

    /// RMS true root strain over `[from, to]`, microstrain.
    pub fn rms_strain_ue(&self, from: f64, to: f64) -> Option<f64> {
        let w: Vec<f64> = self
            .ticks
            .iter()
            .filter(|k| k.t >= from - 1e-9 && k.t <= to + 1e-9)
            .map(|k| k.root_strain * 1e6)
            .collect();
        (!w.is_empty()).then(|| (w.iter().map(|x| x * x).sum::<f64>() / w.len() as f64).sqrt())
    }
}

/// A drive that takes commands: model-core's handler on the host, or the firmware under
/// QEMU (`beam_tools::link::pil_host`).
pub trait CommandedDrive {
    /// Carries out a command before the next tick.
    fn handle(&mut self, request: &Request) -> Result<Reply, SimError>;
    /// One tick.
    fn tick(&mut self, raw: &RawMeasurement) -> Result<TorqueCommand, SimError>;
    /// The first half of [`CommandedDrive::handle`]: the command planned on the drive's
    /// state now, to be applied by [`CommandedDrive::apply`] after some ticks. A drive that
    /// cannot split a command (the default) plans it when it is applied.
    fn prepare(&mut self, request: &Request) -> Result<Pending, SimError> {
        Ok(Pending {
            request: request.clone(),
            action: None,
        })
    }
    /// The second half: what [`CommandedDrive::prepare`] made, applied now.
    fn apply(&mut self, pending: Pending) -> Result<Reply, SimError> {
        self.handle(&pending.request)
    }
}

/// A command prepared and not yet applied ([`CommandedDrive::prepare`]).
#[derive(Clone, Debug, PartialEq)]
pub struct Pending {
    /// The command.
    pub request: Request,
    /// What the handler made of it, if the drive plans ahead.
    pub action: Option<Result<model_core::commands::Action, beam_wire::command::Refusal>>,
}

/// model-core's command handler and controller, run on the host: the drive the firmware
/// is, on a drive's configuration passed in.
#[derive(Clone, Debug, PartialEq)]
pub struct HostDrive<'t> {
    /// The handler.
    pub commander: Commander<'t>,
    /// The controller.
    pub controller: CommandedController,
}

impl<'t> HostDrive<'t> {
    /// The drive running `kind` on `table`'s plant carrying `payload_kg` (the initial
    /// setting), idle at `home_rad`, with settings matching `sensors` (for the `N`-mode
    /// model of that plant). An observer law runs on the table's designs; without them it is
    /// refused, as on a drive.
    pub fn try_new<const N: usize>(
        table: &'t DriveTable<'t>,
        payload_kg: f32,
        kind: LawKind,
        home_rad: f32,
        sensors: &SensorConfig,
    ) -> Result<Self, SimError> {
        let (commander, law) = Commander::try_new(table, kind, payload_kg)
            .map_err(|e| SimError::Drive(Box::new(e)))?;
        let drive = table.plant.params_with(payload_kg as f64);
        let nominal = ModalModel::<N>::try_build(&model_core::Beam::try_build(drive)?)?;
        let settings = model_core::ControllerSettings {
            theta_home_rad: home_rad,
            ..settings_for(&nominal, sensors)
        };
        // Idle at home: a move of no length until the first command plans a real one.
        let rest =
            Spline::try_build(&[(0.0, home_rad), (1.0, home_rad)]).map_err(SimError::Spline)?;
        let controller = Controller::try_build(settings, law, rest).map_err(SimError::Config)?;
        Ok(Self {
            commander,
            controller,
        })
    }
}

impl CommandedDrive for HostDrive<'_> {
    fn handle(&mut self, request: &Request) -> Result<Reply, SimError> {
        Ok(self.commander.handle(&mut self.controller, request))
    }

    fn tick(&mut self, raw: &RawMeasurement) -> Result<TorqueCommand, SimError> {
        Ok(self.controller.step(raw))
    }

    fn prepare(&mut self, request: &Request) -> Result<Pending, SimError> {
        let snap = self.controller.snapshot();
        Ok(Pending {
            request: request.clone(),
            action: Some(self.commander.prepare(&request.command, &snap)),
        })
    }

    fn apply(&mut self, pending: Pending) -> Result<Reply, SimError> {
        let Some(action) = pending.action else {
            return self.handle(&pending.request);
        };
        let outcome = action.and_then(|a| self.commander.apply(a, &mut self.controller));
        Ok(Reply {
            seq: pending.request.seq,
            outcome: outcome.unwrap_or_else(Outcome::Refused),
        })
    }
}

/// Runs `script` against the beam `plant` with model-core's handler on the host, the
/// drive running `kind` on `table` (see [`HostDrive::try_new`]) carrying `payload_kg` (the
/// initial setting), from rest at `home_rad`.
#[allow(clippy::too_many_arguments)] // the drive's settings, then the run's
pub fn run_commands<const N: usize>(
    plant: BeamParams,
    table: &DriveTable<'_>,
    payload_kg: f32,
    kind: LawKind,
    home_rad: f32,
    script: &[Step],
    sensors: SensorConfig,
) -> Result<CommandedRun, SimError> {
    let mut host = HostDrive::try_new::<N>(table, payload_kg, kind, home_rad, &sensors)?;
    run_script::<N, _>(plant, &mut host, home_rad, script, sensors)
}

/// Runs `script` against the beam `plant` with `drive`, from rest at `home_rad` (where the
/// drive's encoder reads zero).
pub fn run_script<const N: usize, D: CommandedDrive>(
    plant: BeamParams,
    drive: &mut D,
    home_rad: f32,
    script: &[Step],
    sensors: SensorConfig,
) -> Result<CommandedRun, SimError> {
    let build = |params: BeamParams| -> Result<Plant<N>, SimError> {
        Ok(Plant::new(ModalModel::<N>::try_build(
            &model_core::Beam::try_build(params)?,
        )?))
    };
    let mut plant_now = build(plant)?;
    let ts = crate::decimal::f32_decimal(model_core::DEFAULT_TS_S);
    let mut sens = Sensors::new(sensors, home_rad as f64);
    let mut x = State::<N>::at_rest(home_rad as f64);
    let mut run = CommandedRun::default();
    let mut seq: u16 = 0;
    let mut k: usize = 0;
    let mut world = World::default();
    let tick = |plant: &Plant<N>,
                x: &mut State<N>,
                drive: &mut D,
                sens: &mut Sensors,
                world: &mut World,
                run: &mut CommandedRun,
                k: &mut usize|
     -> Result<Mode, SimError> {
        let t = crate::decimal::tick_time(*k, ts);
        let amp_fault = world.amp_fault_ticks > 0;
        world.amp_fault_ticks = world.amp_fault_ticks.saturating_sub(1);
        let raw = sens.read(x.theta, plant.outputs(x).root_strain, amp_fault);
        let cmd = drive.tick(&raw)?;
        run.ticks.push(Tick {
            t,
            theta: x.theta,
            root_strain: plant.outputs(x).root_strain,
            torque_nm: cmd.torque_nm,
            mode: cmd.mode,
            faults: cmd.faults,
        });
        // The load acts on the hub besides the motor, whose torque alone is limited.
        let tau = plant.saturate(cmd.torque_nm as f64) + world.load_nm;
        let Integrator::Rk4 { substeps } = Integrator::default() else {
            unreachable!("the default integrator is RK4")
        };
        let h = ts / substeps as f64;
        *x = (0..substeps).fold(*x, |x, _| plant.rk4_step(&x, tau, h));
        plant.check_validity(x).map_err(|why| {
            SimError::Drive(format!("the beam left the model at {t} s: {why}").into())
        })?;
        *k += 1;
        Ok(cmd.mode)
    };
    // Let the strain offset settle before the first command, as after power-up.
    for _ in 0..50 {
        tick(
            &plant_now, &mut x, drive, &mut sens, &mut world, &mut run, &mut k,
        )?;
    }
    for step in script {
        match step {
            Step::Send(command) => {
                seq = seq.wrapping_add(1).max(1);
                let request = Request {
                    seq,
                    command: command.clone(),
                };
                let t = crate::decimal::tick_time(k, ts);
                let reply = if world.latency_ticks == 0 {
                    drive.handle(&request)?
                } else {
                    let pending = drive.prepare(&request)?;
                    for _ in 0..world.latency_ticks {
                        tick(
                            &plant_now, &mut x, drive, &mut sens, &mut world, &mut run, &mut k,
                        )?;
                    }
                    drive.apply(pending)?
                };
                run.exchanges.push(Exchange { t, request, reply });
            }
            Step::Wait(s) => {
                let n = (s / ts).round() as usize;
                for _ in 0..n {
                    tick(
                        &plant_now, &mut x, drive, &mut sens, &mut world, &mut run, &mut k,
                    )?;
                }
            }
            Step::UntilDone { settle_s, max_s } => {
                let limit = (max_s / ts).round() as usize;
                // One tick first: a move just commanded starts on the next tick.
                let mut mode = tick(
                    &plant_now, &mut x, drive, &mut sens, &mut world, &mut run, &mut k,
                )?;
                let mut n = 1;
                while mode == Mode::Slewing {
                    if n >= limit {
                        return Err(SimError::Option("a move did not end within its wait"));
                    }
                    mode = tick(
                        &plant_now, &mut x, drive, &mut sens, &mut world, &mut run, &mut k,
                    )?;
                    n += 1;
                }
                for _ in 0..(settle_s / ts).round() as usize {
                    tick(
                        &plant_now, &mut x, drive, &mut sens, &mut world, &mut run, &mut k,
                    )?;
                }
            }
            Step::AmpFault(n) => world.amp_fault_ticks = *n,
            Step::Attach(kg) => {
                plant_now = build(BeamParams {
                    tip_mass_kg: *kg,
                    ..plant
                })?;
            }
            Step::Load(nm) => world.load_nm = *nm,
            Step::Sensor(fault) => sens.inject(*fault),
            Step::Latency(n) => world.latency_ticks = *n,
        }
    }
    Ok(run)
}

/// What acts on the drive besides its commands, as the script has set it.
#[derive(Clone, Copy, Debug, Default)]
struct World {
    /// External torque on the hub, N m.
    load_nm: f64,
    /// Ticks the amplifier's fault line stays asserted.
    amp_fault_ticks: u32,
    /// Ticks between a command's snapshot and its application.
    latency_ticks: u32,
}

/// A session that exercises every command: from rest at 0 deg, to 45 deg (with a status
/// during and after), through 10 and -30 deg, the payload changed to 25 g (attached to the
/// beam too), to -90 and then +90 deg (the paper's 180 deg), towards -90 again but stopped
/// 80 ms in, an amplifier fault (the status shows it latched), the fault cleared, and
/// a last move back to 0 deg; each move in the shortest time the planner allows.
pub fn session_script() -> Vec<Step> {
    const DEG: f32 = core::f32::consts::PI / 180.0;
    let move_to = |deg: f32| {
        Step::Send(Command::MoveTo {
            to_rad: deg * DEG,
            time_s: None,
        })
    };
    let done = || Step::UntilDone {
        settle_s: 0.4,
        max_s: 5.0,
    };
    let via = |deg: &[f32]| {
        Step::Send(Command::MoveThrough {
            waypoints: deg
                .iter()
                .map(|d| beam_wire::command::Waypoint {
                    rad: d * DEG,
                    at_s: None,
                })
                .collect(),
            time_s: None,
        })
    };
    vec![
        move_to(45.0),
        Step::Wait(0.05),
        Step::Send(Command::Status),
        done(),
        Step::Send(Command::Status),
        via(&[10.0, -30.0]),
        done(),
        Step::Attach(0.025),
        Step::Send(Command::SetPayload { kg: 0.025 }),
        move_to(-90.0),
        done(),
        move_to(90.0),
        done(),
        move_to(-90.0),
        Step::Wait(0.08),
        Step::Send(Command::Stop),
        done(),
        Step::Send(Command::Status),
        Step::AmpFault(3),
        Step::Wait(0.01),
        Step::Send(Command::Status),
        Step::Send(Command::ClearFault),
        Step::Wait(0.3),
        move_to(0.0),
        done(),
        Step::Send(Command::Status),
    ]
}
