// The drive's law and payload: included by `config.rs` and by the build script, which
// computes the start button's moves for them on the host.

/// The payload this drive carries, kg.
pub const PAYLOAD_KG: f32 = 0.0;
/// The control law the drive runs.
pub const CONTROLLER: LawKind = LawKind::Smc;
