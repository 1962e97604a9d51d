//! Parameter sets as TOML files: what `beam calibrate` writes and `--params FILE` reads, so an
//! identified model feeds `simulate`, `optimize` and `sweep` directly.

use model_core::{Beam, BeamParams};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// The file's fields: every `BeamParams` field, SI units, no extras.
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
    tip_mass_kg: f64,
    damping_ratio: f64,
    root_gauge_m: f64,
    mid_gauge_m: f64,
    torque_limit_nm: f64,
}

/// `params` as TOML, with a comment line on top.
pub fn render(params: &BeamParams, comment: &str) -> String {
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
        tip_mass_kg: p.tip_mass_kg,
        damping_ratio: p.damping_ratio,
        root_gauge_m: p.root_gauge_m,
        mid_gauge_m: p.mid_gauge_m,
        torque_limit_nm: p.torque_limit_nm,
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
        tip_mass_kg: f.tip_mass_kg,
        damping_ratio: f.damping_ratio,
        root_gauge_m: f.root_gauge_m,
        mid_gauge_m: f.mid_gauge_m,
        torque_limit_nm: f.torque_limit_nm,
    };
    Beam::try_build(p).map_err(|e| err(e.into()))?;
    Ok(p)
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
        std::fs::write(&path, render(&p, "x") + "colour = 3\n").unwrap();
        let e = load(&path).unwrap_err();
        assert!(
            matches!(&e.reason, ParamsFileReason::Syntax(m) if m.contains("unknown field")),
            "{e:?}"
        );
        std::fs::remove_dir_all(dir).ok();
    }
}
