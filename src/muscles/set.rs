//! The model's muscles with their paths, compiled once, and their per-frame
//! geometry: length, lengthening speed, the generalized force of a unit
//! tension (moment arms), and strength (maximum active fiber force with a
//! rigid tendon, passive fiber force).

use crate::dynamics::Data;
use crate::error::Result;
use crate::model::Model;
use crate::muscles::Muscle;
use crate::parse::osim::ModelSpec;
use crate::paths::coupling;
use crate::paths::geometry::{self, PathState};
use crate::paths::{compile_wrap_objects, BodyWrapObject, GeometryPath};
use crate::xml::Element;

#[derive(Debug, Clone)]
pub struct PathMuscle {
    pub muscle: Muscle,
    pub path: GeometryPath,
    /// Index of the element in the (possibly extended) ForceSet.
    pub force_index: usize,
}

#[derive(Debug, Clone, Default)]
pub struct MuscleSet {
    pub muscles: Vec<PathMuscle>,
    pub wrap_objects: Vec<BodyWrapObject>,
}

/// Whether an element is a muscle type statopt models.
pub fn is_muscle(el: &Element) -> bool {
    el.name.ends_with("Muscle")
}

impl MuscleSet {
    /// Compile the muscles among `forces` (ForceSet order). Muscle types
    /// other than Thelen2003Muscle and Millard2012EquilibriumMuscle are refused
    /// with the element's location.
    pub fn compile(spec: &ModelSpec, forces: &[Element], model: &Model) -> Result<MuscleSet> {
        let wrap_objects = compile_wrap_objects(model, &spec.wrap_objects)?;
        let mut muscles = Vec::new();
        for (i, el) in forces.iter().enumerate() {
            if !is_muscle(el) {
                continue;
            }
            let muscle = Muscle::from_xml_with_version(el, spec.version as i64)?;
            let gp = el
                .child("GeometryPath")
                .or_else(|| el.child("path"))
                .ok_or_else(|| el.error("muscle has no GeometryPath"))?;
            let path = GeometryPath::from_xml(gp, model, &wrap_objects)
                .map_err(|e| e.context(format!("muscle '{}'", muscle.name)))?;
            muscles.push(PathMuscle {
                muscle,
                path,
                force_index: i,
            });
        }
        Ok(MuscleSet {
            muscles,
            wrap_objects,
        })
    }

    pub fn len(&self) -> usize {
        self.muscles.len()
    }
    pub fn is_empty(&self) -> bool {
        self.muscles.is_empty()
    }
}

/// Per-frame muscle geometry, one entry per muscle; buffers are reused.
#[derive(Debug, Clone, Default)]
pub struct MuscleFrame {
    pub length: Vec<f64>,
    pub speed: Vec<f64>,
    /// Generalized force of a unit tension, `unit_force[m][j]` (all speeds).
    pub unit_force: Vec<Vec<f64>>,
    /// Maximum active fiber force along the tendon at full activation, rigid tendon.
    pub max_active_force: Vec<f64>,
    pub passive_force: Vec<f64>,
    paths: Vec<PathState>,
}

impl MuscleFrame {
    pub fn new(set: &MuscleSet, model: &Model) -> Self {
        let n = set.len();
        MuscleFrame {
            length: vec![0.0; n],
            speed: vec![0.0; n],
            unit_force: vec![vec![0.0; model.nq()]; n],
            max_active_force: vec![0.0; n],
            passive_force: vec![0.0; n],
            paths: vec![PathState::default(); n],
        }
    }

    /// Evaluate every muscle at the state in `data` (kinematics done).
    pub fn evaluate(&mut self, set: &MuscleSet, model: &Model, data: &Data) {
        for (m, pm) in set.muscles.iter().enumerate() {
            let st = &mut self.paths[m];
            geometry::evaluate(model, &pm.path, &set.wrap_objects, data, st);
            self.length[m] = st.length;
            self.speed[m] = geometry::lengthening_speed(&pm.path, data, st);
            let f = &mut self.unit_force[m];
            f.iter_mut().for_each(|x| *x = 0.0);
            geometry::add_unit_tension_force(model, &pm.path, data, st, f);
            self.max_active_force[m] = pm
                .muscle
                .max_active_fiber_force_rigid_tendon(st.length, self.speed[m]);
            self.passive_force[m] = pm.muscle.passive_fiber_force_rigid_tendon(st.length);
        }
    }

    /// Moment arm of muscle `m` about coordinate `k` (OpenSim's sign: positive
    /// when tension produces a positive generalized force).
    pub fn moment_arm(&self, model: &Model, q: &[f64], m: usize, k: usize) -> f64 {
        coupling::project(model, q, k, &self.unit_force[m])
    }

    /// The current path of muscle `m` (points in ground), e.g. for display.
    pub fn path_state(&self, m: usize) -> &PathState {
        &self.paths[m]
    }
}
