//! The model's muscles with their paths, compiled once, and their per-frame
//! geometry: length, lengthening speed, the generalized force of a unit
//! tension (moment arms), and strength (maximum active fiber force with a
//! rigid tendon, passive fiber force).

use crate::dynamics::Data;
use crate::error::Result;
use crate::model::Model;
use crate::muscles::thelen2003::{fv_inv_lockstep, FvPending, RigidTendonForces, Thelen2003};
use crate::muscles::{Muscle, MuscleModel};
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

/// Thelen muscles whose force–velocity curves are inverted together.
const LANES: usize = 4;

/// A Thelen muscle waiting in a lane: its index, model and strength.
type Lane<'a> = (usize, &'a Thelen2003, FvPending);

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
            geometry::evaluate(&pm.path, &set.wrap_objects, data, st);
            self.length[m] = st.length;
            self.speed[m] = geometry::lengthening_speed(st);
            let f = &mut self.unit_force[m];
            f.iter_mut().for_each(|x| *x = 0.0);
            geometry::add_unit_tension_force(model, data, st, f);
        }
        // Strengths after the paths, Thelen muscles' force–velocity
        // inversions [`LANES`] at a time in lockstep (bit for bit each
        // muscle's `rigid_tendon_forces`).
        let mut lanes: [Option<Lane>; LANES] = [None; LANES];
        let mut filled = 0;
        for (m, pm) in set.muscles.iter().enumerate() {
            let (length, speed) = (self.length[m], self.speed[m]);
            let lane = match &pm.muscle.model {
                MuscleModel::Thelen2003(t) => {
                    match t.rigid_tendon_forces_begin(&pm.muscle.params, length, speed) {
                        RigidTendonForces::Known(active, passive) => {
                            (self.max_active_force[m], self.passive_force[m]) = (active, passive);
                            continue;
                        }
                        RigidTendonForces::NeedsFv(pending) => (m, t, pending),
                    }
                }
                MuscleModel::Millard2012(_) => {
                    (self.max_active_force[m], self.passive_force[m]) =
                        pm.muscle.rigid_tendon_forces(length, speed);
                    continue;
                }
            };
            lanes[filled] = Some(lane);
            filled += 1;
            if filled == LANES {
                let full = lanes.map(|l| l.expect("every lane filled"));
                let fv = fv_inv_lockstep(full.map(|(_, t, _)| t), &full.map(|(_, _, p)| p));
                for ((m, t, pending), fv) in full.into_iter().zip(fv) {
                    (self.max_active_force[m], self.passive_force[m]) = pending.finish(t, fv);
                }
                filled = 0;
            }
        }
        for &(m, t, pending) in lanes[..filled].iter().flatten() {
            let fv = t.fv_inv(1.0, pending.fal, pending.norm_fiber_velocity, 1e-6, 100);
            (self.max_active_force[m], self.passive_force[m]) = pending.finish(t, fv);
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dynamics::kinematics;
    use crate::paths::geometry::Origin;
    use crate::paths::PointKind;
    use nalgebra::Vector3;

    /// q in each coordinate's range (clipped to ±3) at `state(k, 0)` of
    /// the way, u = scale · state(k, phase), and the kinematics of that
    /// state.
    fn set_state(
        model: &Model,
        data: &mut Data,
        state: impl Fn(usize, f64) -> f64,
        (scale, phase): (f64, f64),
    ) {
        for (k, c) in model.coordinates.iter().enumerate() {
            let [lo, hi] = c.range;
            let (lo, hi) = (lo.max(-3.0), hi.min(3.0));
            data.q[k] = lo + (hi - lo) * 0.5 * (1.0 + state(k, 0.0));
            data.u[k] = scale * state(k, phase);
        }
        kinematics::full(model, data);
    }

    /// The shipped leg extension humans (a Thelen model and a Millard
    /// one): file name, model and muscle set.
    fn leg_extension_models() -> Vec<(&'static str, Model, MuscleSet)> {
        ["human_seated.osim", "human_seated_rajagopal.osim"]
            .into_iter()
            .map(|name| {
                let file = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
                    .join("models/leg_extension")
                    .join(name);
                let (spec, model) = crate::tools::loading::load_model(&file).unwrap();
                let set = MuscleSet::compile(&spec, &spec.forces, &model).unwrap();
                (name, model, set)
            })
            .collect()
    }

    /// `MuscleFrame::evaluate`'s strengths (Thelen muscles inverted four
    /// at a time in lockstep, the rest one by one) equal each muscle's
    /// `rigid_tendon_forces` bit for bit, on a Thelen model and on a
    /// Millard one, over varied states.
    #[test]
    fn frame_strengths_are_each_muscles_rigid_tendon_forces() {
        let mut active = 0;
        for (name, model, set) in leg_extension_models() {
            let mut data = Data::new(&model);
            let mut mf = MuscleFrame::new(&set, &model);
            for trial in 0..20 {
                let state = |k: usize, s: f64| ((k * 5 + trial * 11) as f64 * 0.29 + s).sin();
                set_state(&model, &mut data, state, (3.0, 2.1));
                mf.evaluate(&set, &model, &data);
                for (m, pm) in set.muscles.iter().enumerate() {
                    let (a, p) = pm.muscle.rigid_tendon_forces(mf.length[m], mf.speed[m]);
                    assert_eq!(
                        mf.max_active_force[m].to_bits(),
                        a.to_bits(),
                        "{name} {}",
                        pm.muscle.name
                    );
                    assert_eq!(
                        mf.passive_force[m].to_bits(),
                        p.to_bits(),
                        "{name} {}",
                        pm.muscle.name
                    );
                    active += usize::from(a != 0.0);
                }
            }
        }
        assert!(active > 100, "{active} nonzero strengths");
    }

    /// The per-point values `geometry::evaluate` keeps (ground velocity,
    /// moving points' ∂p/∂q) equal fresh evaluations bit for bit, and so
    /// does the lengthening speed made from them, on models with
    /// conditional and moving points and with wrapping.
    #[test]
    fn kept_point_motion_matches_fresh_evaluation() {
        let (mut moving, mut wrapped) = (0, 0);
        for (_, model, set) in leg_extension_models() {
            assert!(!set.is_empty());
            check_point_motion(&set, &model, &mut moving, &mut wrapped);
        }
        assert!(
            moving > 0 && wrapped > 0,
            "moving {moving} wrapped {wrapped}"
        );
    }

    fn check_point_motion(set: &MuscleSet, model: &Model, moving: &mut usize, wrapped: &mut usize) {
        let mut data = Data::new(model);
        let mut mf = MuscleFrame::new(set, model);
        for trial in 0..6 {
            let state = |k: usize, s: f64| ((k * 7 + trial * 3) as f64 * 0.37 + s).sin();
            set_state(model, &mut data, state, (1.0, 1.3));
            mf.evaluate(set, model, &data);
            for (m, pm) in set.muscles.iter().enumerate() {
                let st = mf.path_state(m);
                let mut fresh = Vec::new();
                for p in &st.points {
                    let mut v = data.station_velocity(p.body, &p.local);
                    match p.origin {
                        Origin::Point(i) => match &pm.path.points[i].kind {
                            PointKind::Moving {
                                coordinate,
                                functions,
                                ..
                            } => {
                                let q = data.q[*coordinate];
                                let d = Vector3::new(
                                    functions[0].derivative(q, 1),
                                    functions[1].derivative(q, 1),
                                    functions[2].derivative(q, 1),
                                );
                                let frame_rot = pm.path.points[i].frame.rotation;
                                let dp = data.rotation[p.body] * (frame_rot * d);
                                assert_eq!(p.moving, Some((*coordinate, dp)));
                                v += dp * data.u[*coordinate];
                                *moving += 1;
                            }
                            _ => assert_eq!(p.moving, None),
                        },
                        Origin::Wrap { .. } => {
                            assert_eq!(p.moving, None);
                            *wrapped += 1;
                        }
                    }
                    assert_eq!(p.velocity, v, "{} trial {trial}", pm.muscle.name);
                    fresh.push(v);
                }
                // The speed from fresh velocities, as it was computed before
                // the velocities were kept.
                let mut speed = 0.0;
                for (w, v) in st.points.windows(2).zip(fresh.windows(2)) {
                    let d = w[0].ground - w[1].ground;
                    let dv = v[0] - v[1];
                    let n = d.norm();
                    speed += if n < f64::EPSILON {
                        dv.norm()
                    } else {
                        dv.dot(&d) / n
                    };
                }
                assert_eq!(mf.speed[m].to_bits(), speed.to_bits(), "{}", pm.muscle.name);
            }
        }
    }
}
