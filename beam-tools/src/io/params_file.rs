//! Parameter sets as TOML files: what `beam calibrate` writes and `--params FILE` reads, so an
//! identified model feeds `simulate`, `optimize` and `sweep` directly.

use model_core::{Beam, BeamParams};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// How a rig's logs read the physics (the `[sensors]` table of a parameter file): what
/// `beam calibrate --method split` finds besides the beam, and what `beam replay` applies to
/// a log before putting the model against it. The model itself (`simulate`, `optimize`,
/// `sweep`) does not use them: they describe the instruments, not the beam.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Sensors {
    /// The logged torque over the torque the hub received (1: the torque reads true).
    pub torque_scale: f64,
    /// The logged torque with none applied, N m (a bias of the torque's measurement or
    /// estimate: the same in both directions of motion, unlike Coulomb friction).
    pub torque_offset_nm: f64,
    /// The root gauge's reading over the strain the beam's curvature implies (or a tip
    /// sensor's over the deflection, for a log of the tip).
    pub gauge_scale: f64,
    /// How long the beam's sensor (root gauge or tip sensor) reads behind the hub's encoder,
    /// s: `beam replay` takes a log's readings this much later before it compares.
    pub strain_delay_s: f64,
}

impl Default for Sensors {
    fn default() -> Self {
        Self {
            torque_scale: 1.0,
            torque_offset_nm: 0.0,
            gauge_scale: 1.0,
            strain_delay_s: 0.0,
        }
    }
}

impl Sensors {
    /// The torque the hub received when the log says `logged`.
    pub fn applied_torque(&self, logged: f64) -> f64 {
        (logged - self.torque_offset_nm) / self.torque_scale
    }

    /// Why these cannot be used, if they cannot: the scales must be finite and positive,
    /// the offset finite.
    pub fn check(&self) -> Result<(), String> {
        for (name, v) in [
            ("torque_scale", self.torque_scale),
            ("gauge_scale", self.gauge_scale),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Err(format!("sensors.{name}: {v} must be finite and > 0"));
            }
        }
        if !(0.0..=0.5).contains(&self.strain_delay_s) {
            return Err(format!(
                "sensors.strain_delay_s: {} must be within 0 to 0.5 s",
                self.strain_delay_s
            ));
        }
        if !self.torque_offset_nm.is_finite() {
            return Err(format!(
                "sensors.torque_offset_nm: {} must be finite",
                self.torque_offset_nm
            ));
        }
        Ok(())
    }
}

/// The file's fields: every `BeamParams` field, SI units, and the optional `[sensors]`.
#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct File {
    length_m: f64,
    width_m: f64,
    thickness_m: f64,
    hub_radius_m: f64,
    density_kg_m3: f64,
    ei_nm2: f64,
    jm_kgm2: f64,
    viscous_nms: f64,
    coulomb_nm: f64,
    #[serde(default, skip_serializing_if = "is_zero")]
    coulomb_asym_nm: f64,
    tip_mass_kg: f64,
    damping_ratio: f64,
    root_gauge_m: f64,
    mid_gauge_m: f64,
    torque_limit_nm: f64,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    sensors: Option<Sensors>,
}

/// Whether a key is left out of a written file: a friction that is the same both ways.
fn is_zero(v: &f64) -> bool {
    *v == 0.0
}

/// `params` as TOML, with a comment line on top.
pub fn render(params: &BeamParams, comment: &str) -> String {
    render_with(params, None, comment)
}

/// `params` and, if given, the rig's `[sensors]` as TOML, with a comment line on top.
pub fn render_with(params: &BeamParams, sensors: Option<&Sensors>, comment: &str) -> String {
    let p = params;
    let f = File {
        length_m: p.length_m,
        width_m: p.width_m,
        thickness_m: p.thickness_m,
        hub_radius_m: p.hub_radius_m,
        density_kg_m3: p.density_kg_m3,
        ei_nm2: p.ei_nm2,
        jm_kgm2: p.jm_kgm2,
        viscous_nms: p.viscous_nms,
        coulomb_nm: p.coulomb_nm,
        coulomb_asym_nm: p.coulomb_asym_nm,
        tip_mass_kg: p.tip_mass_kg,
        damping_ratio: p.damping_ratio,
        root_gauge_m: p.root_gauge_m,
        mid_gauge_m: p.mid_gauge_m,
        torque_limit_nm: p.torque_limit_nm,
        sensors: sensors.copied(),
    };
    format!("# {comment}\n{}", toml::to_string(&f).unwrap_or_default())
}

/// A parameter file that could not be used: which file, and why.
#[derive(Debug, thiserror::Error)]
#[error("{}", .path.display())]
pub struct ParamsFileError {
    /// The file.
    pub path: std::path::PathBuf,
    /// Why.
    #[source]
    pub reason: ParamsFileReason,
}

/// Why a parameter file could not be used.
#[derive(Debug, thiserror::Error)]
pub enum ParamsFileReason {
    /// It could not be read.
    #[error(transparent)]
    Read(#[from] std::io::Error),
    /// It is not a parameter file (TOML syntax, a missing or unknown key).
    #[error("{0}")]
    Syntax(String),
    /// A value is invalid.
    #[error(transparent)]
    Invalid(#[from] model_core::ParamError),
}

/// Reads and validates a parameter file; errors name the file and the field.
pub fn load(path: &Path) -> Result<BeamParams, ParamsFileError> {
    load_with_sensors(path).map(|(p, _)| p)
}

/// Reads and validates a parameter file and its `[sensors]` (the defaults, true readings,
/// if it has none).
pub fn load_with_sensors(path: &Path) -> Result<(BeamParams, Sensors), ParamsFileError> {
    let err = |reason| ParamsFileError {
        path: path.to_path_buf(),
        reason,
    };
    let text = std::fs::read_to_string(path).map_err(|e| err(e.into()))?;
    let f: File = toml::from_str(&text)
        .map_err(|e| err(ParamsFileReason::Syntax(e.message().trim().to_string())))?;
    let p = BeamParams {
        length_m: f.length_m,
        width_m: f.width_m,
        thickness_m: f.thickness_m,
        hub_radius_m: f.hub_radius_m,
        density_kg_m3: f.density_kg_m3,
        ei_nm2: f.ei_nm2,
        jm_kgm2: f.jm_kgm2,
        viscous_nms: f.viscous_nms,
        coulomb_nm: f.coulomb_nm,
        coulomb_asym_nm: f.coulomb_asym_nm,
        tip_mass_kg: f.tip_mass_kg,
        damping_ratio: f.damping_ratio,
        root_gauge_m: f.root_gauge_m,
        mid_gauge_m: f.mid_gauge_m,
        torque_limit_nm: f.torque_limit_nm,
    };
    Beam::try_build(p).map_err(|e| err(e.into()))?;
    let sensors = f.sensors.unwrap_or_default();
    sensors
        .check()
        .map_err(|m| err(ParamsFileReason::Syntax(m)))?;
    Ok((p, sensors))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trips_and_rejects_bad_values() {
        let dir = std::env::temp_dir().join(format!("beam-preset-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("p.toml");
        let p = BeamParams::aluminium();
        std::fs::write(&path, render(&p, "test")).unwrap();
        assert_eq!(load(&path).unwrap(), p);
        std::fs::write(&path, render(&p, "x").replace("ei_nm2 = ", "ei_nm2 = -")).unwrap();
        let e = load(&path).unwrap_err();
        assert_eq!(e.path, path);
        assert!(
            matches!(e.reason, ParamsFileReason::Invalid(p) if p.field == "ei_nm2"),
            "{e:?}"
        );
        let sensors = Sensors {
            torque_scale: 1.05,
            torque_offset_nm: -0.01,
            gauge_scale: 1.2,
            strain_delay_s: 0.015,
        };
        std::fs::write(&path, render_with(&p, Some(&sensors), "test")).unwrap();
        assert_eq!(load_with_sensors(&path).unwrap(), (p, sensors));
        assert_eq!(load(&path).unwrap(), p);
        let bad =
            render_with(&p, Some(&sensors), "x").replace("gauge_scale = 1.2", "gauge_scale = 0");
        let e = load(&path).and_then(|_| {
            std::fs::write(&path, bad).unwrap();
            load(&path)
        });
        assert!(
            matches!(&e, Err(ParamsFileError { reason: ParamsFileReason::Syntax(m), .. }) if m.contains("gauge_scale")),
            "{e:?}"
        );
        std::fs::write(&path, render(&p, "x")).unwrap();
        assert_eq!(load_with_sensors(&path).unwrap().1, Sensors::default());
        std::fs::write(&path, render(&p, "x") + "colour = 3\n").unwrap();
        let e = load(&path).unwrap_err();
        assert!(
            matches!(&e.reason, ParamsFileReason::Syntax(m) if m.contains("unknown field")),
            "{e:?}"
        );
        std::fs::remove_dir_all(dir).ok();
    }
}
