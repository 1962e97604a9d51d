//! The repository's shipped gain table, loaded at run time as the host tools load a table:
//! the drive configuration the tests run against where they want the shipped gains, and a
//! commanded run on it.

// Each test file uses some of these.
#![allow(dead_code)]

use model_core::DriveTable;
use std::sync::OnceLock;

/// The shipped `gains.toml`, loaded once.
pub fn shipped() -> &'static DriveTable<'static> {
    static TABLE: OnceLock<&'static DriveTable<'static>> = OnceLock::new();
    TABLE.get_or_init(|| {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../gains.toml");
        gain_table::open(&path)
            .expect("the shipped gain table loads")
            .leak()
    })
}

/// `script` on the aluminium beam (3 modes) against the drive of the shipped table running
/// `kind` at no payload, from rest at 0 with the reference sensors; a breakdown as its text.
pub fn run_shipped(
    kind: model_core::LawKind,
    script: &[beam_sim::commanded::Step],
) -> Result<beam_sim::commanded::CommandedRun, String> {
    beam_sim::commanded::run_commands::<3>(
        model_core::BeamParams::aluminium(),
        shipped(),
        0.0,
        kind,
        0.0,
        script,
        beam_sim::sensors::SensorConfig::default(),
    )
    .map_err(|e| e.to_string())
}

/// A drive that records the observer laws' state after each tick (`model_core`'s
/// `ObserverState`: the estimate, the reference beam, the identifier), else the controller
/// itself.
pub struct Recording<const K: usize> {
    pub controller: model_core::Controller<K>,
    pub states: Vec<model_core::law::ObserverState>,
}

impl<const K: usize> Recording<K> {
    /// Recording `controller`'s ticks, from none.
    pub fn new(controller: model_core::Controller<K>) -> Self {
        Self {
            controller,
            states: vec![],
        }
    }
}

impl<const K: usize> beam_sim::sim::DriveLoop for Recording<K> {
    fn settings(&self) -> &model_core::ControllerSettings {
        self.controller.settings()
    }

    fn tick(
        &mut self,
        raw: &model_core::RawMeasurement,
        start: bool,
    ) -> Result<model_core::TorqueCommand, beam_sim::sim::SimError> {
        let cmd = beam_sim::sim::DriveLoop::tick(&mut self.controller, raw, start)?;
        self.states.push(self.controller.law_state().lqg);
        Ok(cmd)
    }

    fn faults(&self) -> model_core::FaultFlags {
        self.controller.faults()
    }

    fn feed_truth(&mut self, x: &[f32; model_core::lqg::MAX_STATES]) {
        self.controller.feed_truth(x)
    }
}
