//! The table's `[plant]`: the beam its gains were designed for, and the plant compiled in
//! with it (`beam_model::plant::Plant`, computed here on the host).
//!
//! ```toml
//! [plant]
//! modes = 3
//! preset = "aluminium"     # a preset, or instead every field of a parameter file
//! # length_m = 0.4842      # (as `beam calibrate` writes one), tip_mass_kg = 0
//! ```

use crate::Row;
use beam_kinds::Preset;
use beam_model::modal::MAX_MODES;
use beam_model::plant::{Plant, PlantPoint};
use beam_model::{Beam, BeamParams, ModalModel};

/// Widest step of the table of the first clamped frequency over the payload, kg (the one
/// number of the plant that is interpolated; see `beam_model::plant::Plant`).
pub const PLANT_STEP_KG: f64 = 0.005;

/// Widest step of the observer laws' designs over the payload, kg: the drive schedules the
/// quadratic through each three of them (`model_core::table::schedule_design`), which at
/// this step stays closer to the design made at the payload than the straight line did
/// through designs [`PLANT_STEP_KG`] apart (docs/design-gains.md, "The observer designs
/// between payloads"), with 9 designs a law on the shipped table where it took 13.
pub const DESIGN_STEP_KG: f64 = 0.00625;

/// The beam a table's gains were designed for.
#[derive(Clone, Debug, PartialEq)]
pub struct PlantSpec {
    /// The preset the parameters start from, if any (rendered back as such when nothing
    /// overrides it).
    pub preset: Option<Preset>,
    /// The beam, tip mass zero: the rows' `payload_kg` is the payload.
    pub params: BeamParams,
    /// Flexible modes of the model (1 to 4).
    pub modes: usize,
}

/// A `[plant]` error: the field (if one) and why.
pub(crate) type PlantError = (Option<&'static str>, String);

/// Zero and every row's payload (as the drive's `f32` holds it), each step between two split
/// into a multiple of `multiple` equal steps no wider than `step_kg`.
fn grid(rows: &[Row], step_kg: f64, multiple: usize) -> Vec<f64> {
    let mut knots: Vec<f64> = rows.iter().map(|r| r.payload_kg as f32 as f64).collect();
    knots.push(0.0);
    knots.sort_by(f64::total_cmp);
    knots.dedup();
    let mut out = vec![knots[0]];
    for pair in knots.windows(2) {
        let (a, b) = (pair[0], pair[1]);
        // (Less a hair: a row's payload in f32 is a hair off its decimal, 12.5 g two 6.25 g
        // steps and not four.)
        let steps = (b - a) / (step_kg * multiple as f64) - 1e-6;
        let n = steps.ceil().max(1.0) as usize * multiple;
        for k in 1..n {
            out.push((a + (b - a) * k as f64 / n as f64) as f32 as f64);
        }
        out.push(b);
    }
    out
}

impl PlantSpec {
    /// A preset's beam with an `modes`-mode model.
    pub fn preset(preset: Preset, modes: usize) -> Self {
        Self {
            preset: Some(preset),
            params: BeamParams::preset(preset),
            modes,
        }
    }

    /// The beam `params` (its tip mass is dropped: the rows carry the payload).
    pub fn params(params: BeamParams, modes: usize) -> Self {
        Self {
            preset: None,
            params: BeamParams {
                tip_mass_kg: 0.0,
                ..params
            },
            modes,
        }
    }

    pub(crate) fn from_value(v: &toml::Value) -> Result<Self, PlantError> {
        let why = |m: &str| format!("[plant]: {}", m.trim());
        let mut keys = v
            .as_table()
            .cloned()
            .ok_or((None, why("must be a table")))?;
        let modes = match keys.remove("modes") {
            Some(toml::Value::Integer(n)) if (1..=MAX_MODES as i64).contains(&n) => n as usize,
            Some(n) => {
                return Err((
                    Some("modes"),
                    why(&format!("{n} modes: the model has 1 to 4")),
                ))
            }
            None => return Err((Some("modes"), why("missing `modes`"))),
        };
        let preset = match keys.remove("preset") {
            None => None,
            Some(name) => Some(
                name.try_into::<Preset>()
                    .map_err(|e| (Some("preset"), why(e.message())))?,
            ),
        };
        let params = match preset {
            Some(p) if keys.is_empty() => BeamParams::preset(p),
            Some(_) => {
                return Err((
                    None,
                    why("a `preset` or the beam's fields, not both (write the preset's fields out to change one)"),
                ))
            }
            None => toml::Value::Table(keys)
                .try_into::<BeamParams>()
                .map_err(|e| (None, why(e.message())))?,
        };
        if params.tip_mass_kg != 0.0 {
            return Err((
                Some("tip_mass_kg"),
                why(&format!(
                    "{} kg: the plant carries no payload (the rows' payload_kg is it)",
                    params.tip_mass_kg
                )),
            ));
        }
        let spec = Self {
            preset,
            params,
            modes,
        };
        spec.point(0.0)?;
        Ok(spec)
    }

    /// The `[plant]` table's text: the preset alone when the beam is the preset's, else
    /// every field.
    pub fn render(&self) -> String {
        let beam = match self.preset {
            Some(p) if BeamParams::preset(p) == self.params => {
                format!("preset = \"{}\"\n", p.name())
            }
            _ => toml::to_string(&self.params).unwrap_or_else(|e| format!("# {e}\n")),
        };
        format!("[plant]\nmodes = {}\n{beam}", self.modes)
    }

    /// The model with `payload_kg` at the tip.
    fn model<const N: usize>(&self, payload_kg: f64) -> Result<ModalModel<N>, PlantError> {
        let beam = Beam::try_build(BeamParams {
            tip_mass_kg: payload_kg,
            ..self.params
        })
        .map_err(|e| (Some(e.field), format!("[plant]: {e}")))?;
        ModalModel::<N>::try_build(&beam).map_err(|e| (None, format!("[plant]: {e}")))
    }

    /// The plant at `payload_kg`, from the exact model (what [`Plant::at`] must match).
    pub fn point(&self, payload_kg: f64) -> Result<PlantPoint, PlantError> {
        match self.modes {
            1 => Ok(PlantPoint::of(&self.model::<1>(payload_kg)?)),
            2 => Ok(PlantPoint::of(&self.model::<2>(payload_kg)?)),
            3 => Ok(PlantPoint::of(&self.model::<3>(payload_kg)?)),
            4 => Ok(PlantPoint::of(&self.model::<4>(payload_kg)?)),
            n => Err((Some("modes"), format!("[plant]: {n} modes"))),
        }
    }

    /// The payloads the first frequency is tabulated at for `rows`: zero, every row's
    /// payload (as the drive's `f32` holds it), and enough points between that no step
    /// exceeds [`PLANT_STEP_KG`].
    pub fn payloads(rows: &[Row]) -> Vec<f64> {
        grid(rows, PLANT_STEP_KG, 1)
    }

    /// The payloads the observer laws are designed at for `rows`: zero, every row's payload
    /// and, between each two, an even number of equal steps no wider than
    /// [`DESIGN_STEP_KG`], so that the drive's threes of designs (`0, 1, 2`, `2, 3, 4`, ...)
    /// each lie between two rows of gains.
    pub fn design_payloads(rows: &[Row]) -> Vec<f64> {
        grid(rows, DESIGN_STEP_KG, 2)
    }

    /// The compiled plant for `rows` (see [`Plant`]): payloads from 0 to the heaviest row.
    pub fn plant(&self, rows: &[Row]) -> Result<PlantParts, PlantError> {
        match self.modes {
            1 => self.plant_n::<1>(rows),
            2 => self.plant_n::<2>(rows),
            3 => self.plant_n::<3>(rows),
            4 => self.plant_n::<4>(rows),
            n => Err((Some("modes"), format!("[plant]: {n} modes"))),
        }
    }

    fn plant_n<const N: usize>(&self, rows: &[Row]) -> Result<PlantParts, PlantError> {
        let payloads = Self::payloads(rows);
        let m0 = self.model::<N>(0.0)?;
        // S is affine in the payload: its slope is the difference at 1 kg (taken in f64,
        // then rounded once, like every number the drive gets).
        let m1 = self.model::<N>(1.0)?;
        let mut first_hz = Vec::with_capacity(payloads.len());
        for &p in &payloads {
            first_hz.push((p as f32, self.model::<N>(p)?.clamped_hz[0] as f32));
        }
        let plant = Plant::from_models(self.params, &m0, &m1, &[]);
        Ok(PlantParts { plant, first_hz })
    }
}

/// A [`Plant`] as computed, its frequency table (which the compiled plant holds as a
/// `'static` slice) kept apart.
#[derive(Clone, Debug, PartialEq)]
pub struct PlantParts {
    /// The plant, `first_hz` empty.
    pub plant: Plant,
    /// Its `first_hz`.
    pub first_hz: Vec<(f32, f32)>,
}

impl PlantParts {
    /// The plant with its table, which is leaked: for a host tool or a test that needs one
    /// plant for its whole run.
    pub fn leak(self) -> Plant {
        Plant {
            first_hz: Box::leak(self.first_hz.into_boxed_slice()),
            ..self.plant
        }
    }
}

fn point_source(q: &PlantPoint) -> String {
    format!(
        "::model_core::plant::PlantPoint {{ payload_kg: {:?}, torque_limit_nm: {:?}, \
         viscous_nms: {:?}, coulomb_nm: {:?}, mtt: {:?}, jeff: {:?}, root_strain_coef: {:?}, \
         minv_h: {:?}, minv_e: {:?}, kqq_col0: {:?}, cq_col0: {:?}, s_col0: {:?}, \
         strain_per_acc: {:?} }}",
        q.payload_kg,
        q.torque_limit_nm,
        q.viscous_nms,
        q.coulomb_nm,
        q.mtt,
        q.jeff,
        q.root_strain_coef,
        q.minv_h,
        q.minv_e,
        q.kqq_col0,
        q.cq_col0,
        q.s_col0,
        q.strain_per_acc
    )
}

/// Rust source for `PLANT`, the compiled [`Plant`].
pub(crate) fn generate_plant(parts: &PlantParts) -> String {
    let plant = &parts.plant;
    let p = &plant.params;
    let mut out = String::new();
    out.push_str(
        "/// The plant the gain table was designed for (its `[plant]`), computed on the host.\n",
    );
    out.push_str("pub const PLANT: ::model_core::plant::Plant = ::model_core::plant::Plant {\n");
    out.push_str(&format!(
        "    params: ::model_core::BeamParams {{ length_m: {:?}, width_m: {:?}, thickness_m: {:?}, \
         hub_radius_m: {:?}, density_kg_m3: {:?}, ei_nm2: {:?}, jm_kgm2: {:?}, viscous_nms: {:?}, \
         coulomb_nm: {:?}, coulomb_asym_nm: {:?}, tip_mass_kg: {:?}, damping_ratio: {:?}, \
         root_gauge_m: {:?}, mid_gauge_m: {:?}, torque_limit_nm: {:?} }},\n",
        p.length_m,
        p.width_m,
        p.thickness_m,
        p.hub_radius_m,
        p.density_kg_m3,
        p.ei_nm2,
        p.jm_kgm2,
        p.viscous_nms,
        p.coulomb_nm,
        p.coulomb_asym_nm,
        p.tip_mass_kg,
        p.damping_ratio,
        p.root_gauge_m,
        p.mid_gauge_m,
        p.torque_limit_nm
    ));
    out.push_str(&format!(
        "    modes: {},\n    base: {},\n    arm_m: {:?},\n    damping_ratio: {:?},\n    h: {:?},\n    \
         tip_shape: {:?},\n    tip_minv: {:?},\n    s_col0_per_kg: {:?},\n    mqq00: {:?},\n    \
         strain_per_acc_per_kg: {:?},\n    first_hz: &{:?},\n}};\n",
        plant.modes,
        point_source(&plant.base),
        plant.arm_m,
        plant.damping_ratio,
        plant.h,
        plant.tip_shape,
        plant.tip_minv,
        plant.s_col0_per_kg,
        plant.mqq00,
        plant.strain_per_acc_per_kg,
        parts.first_hz
    ));
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The largest relative difference between two points' numbers.
    fn rel_diff(a: &PlantPoint, b: &PlantPoint) -> f64 {
        assert_eq!(a.payload_kg, b.payload_kg);
        let scalars = [
            (a.mtt, b.mtt),
            (a.jeff, b.jeff),
            (a.strain_per_acc, b.strain_per_acc),
        ]
        .map(|(x, y)| (x as f64, y as f64));
        let vectors = [
            (a.root_strain_coef, b.root_strain_coef),
            (a.minv_h, b.minv_h),
            (a.minv_e, b.minv_e),
            (a.kqq_col0, b.kqq_col0),
            (a.cq_col0, b.cq_col0),
            (a.s_col0, b.s_col0),
        ];
        let mut worst = scalars
            .iter()
            .map(|(x, y)| (x - y).abs() / y.abs())
            .fold(0.0, f64::max);
        for (x, y) in vectors {
            let scale = y.iter().fold(0.0f64, |m, &v| m.max((v as f64).abs()));
            for (&u, &v) in x.iter().zip(&y) {
                worst = worst.max((u as f64 - v as f64).abs() / scale);
            }
        }
        worst
    }

    #[test]
    fn the_grid_holds_every_row_payload_and_steps_no_wider_than_the_limit() {
        let rows = crate::parse(
            "[plant]\nmodes = 3\npreset = \"aluminium\"\n\n[[row]]\ncontroller = \"pd\"\n\
             payload_kg = 0.03\nkp = 1.0\nkd = 0.1\ncost_j = 0.0\n",
            "g",
        )
        .unwrap()
        .rows;
        let p = PlantSpec::payloads(&rows);
        assert_eq!(p.first(), Some(&0.0));
        assert_eq!(p.last(), Some(&(0.03f32 as f64)));
        assert!(p
            .windows(2)
            .all(|w| w[1] > w[0] && w[1] - w[0] <= PLANT_STEP_KG * 1.0001));
    }

    #[test]
    fn the_designs_take_an_even_number_of_steps_between_rows() {
        let rows = crate::parse(
            "[plant]\nmodes = 3\npreset = \"aluminium\"\n\n[[row]]\ncontroller = \"pd\"\n\
             payload_kg = 0.0125\nkp = 1.0\nkd = 0.1\ncost_j = 0.0\n\n[[row]]\n\
             controller = \"pd\"\npayload_kg = 0.03\nkp = 1.0\nkd = 0.1\ncost_j = 0.0\n",
            "g",
        )
        .unwrap()
        .rows;
        let p = PlantSpec::design_payloads(&rows);
        let at = |kg: f32| p.iter().position(|&x| x == kg as f64).unwrap();
        // 0 to 12.5 g in two steps, 12.5 to 30 g in four (17.5 g over 4 is within 6.25 g,
        // over 2 it is not).
        assert_eq!((p.len(), at(0.0), at(0.0125), at(0.03)), (7, 0, 2, 6));
        assert!(p
            .windows(2)
            .all(|w| w[1] > w[0] && w[1] - w[0] <= DESIGN_STEP_KG * 1.0001));
    }

    #[test]
    fn the_plant_at_any_payload_is_the_model_built_there() {
        // The shipped table's payloads (0 to 50 g), for 1 to 4 modes: at every tabulated
        // payload and halfway between, the compiled plant against the model built there.
        let text = std::fs::read_to_string(
            std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../gains.toml"),
        )
        .unwrap();
        let rows = crate::parse(&text, "gains.toml").unwrap().rows;
        for modes in 1..=4 {
            let spec = PlantSpec::preset(Preset::Aluminium, modes);
            let plant = spec.plant(&rows).unwrap().leak();
            assert_eq!(plant.max_payload_kg(), 0.05f32);
            let (mut exact, mut between): (f64, f64) = (0.0, 0.0);
            for pair in plant.first_hz.windows(2) {
                let (p, q) = (pair[0].0, pair[1].0);
                let mid = 0.5 * (p + q);
                let model_at = |p: f32| spec.point(p as f64).unwrap();
                exact = exact.max(rel_diff(&plant.at(p).unwrap(), &model_at(p)));
                between = between.max(rel_diff(&plant.at(mid).unwrap(), &model_at(mid)));
            }
            assert_eq!(
                plant.at(0.0),
                Some(spec.point(0.0).unwrap()),
                "{modes} modes"
            );
            // Rounding only: the mass matrices are affine in the payload. The compiled
            // numbers are f32 (to 6e-8) and the update is a few f32 operations on each;
            // 4 steps of f32 (4.8e-7) bound it (2.0e-7 measured).
            let f32_steps = 4.0 * f32::EPSILON as f64;
            assert!(exact < f32_steps, "{modes} modes: {exact:e} on the table");
            // The first frequency interpolated as 1/f^2 every 5 g: exact for one mode (to
            // the same rounding); for more, the first mode's damping term it sets is within
            // 5e-5 (3.0e-5 measured for the aluminium beam, far inside what a damping ratio
            // is known to).
            let limit = if modes == 1 { f32_steps } else { 5e-5 };
            assert!(between < limit, "{modes} modes: {between:e} between");
            // Outside the range there is no plant.
            assert_eq!(plant.at(-1e-9), None);
            assert_eq!(
                plant.at(plant.max_payload_kg() * (1.0 + f32::EPSILON)),
                None
            );
            assert_eq!(plant.at(f32::NAN), None);
        }
    }
}
