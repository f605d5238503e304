//! Model no more than the scene needs (`<reduce_model>true</reduce_model>` in
//! an AnalyzeTool setup, or `statopt-tool SETUP --reduce`): static
//! optimization runs on the model reduced to what the setup's motion moves.
//!
//! The states actually analysed (after the setup's filtering, splining and
//! `<close_contacts>`; the frames of the StaticOptimization's step interval
//! between initial and final time) are scanned once:
//!
//! - A coordinate **moves** when its value spans more than
//!   [`STATIC_TOLERANCE`] over the frames, or its speed or target
//!   acceleration exceeds it anywhere, or it is the dependent coordinate of a
//!   coupler whose independent coordinate moves. An unconstrained coordinate
//!   that does not move is **locked** at its value on the first frame, with
//!   OpenSim's `locked` semantics: q fixed, u = u̇ = 0, and its equation of
//!   motion is no longer a row of the problem (the lock carries that
//!   generalized force, as a weld would).
//! - A joint is **rigid** when none of its coordinates moves. Bodies joined
//!   by rigid joints form rigid clusters; joints named by a JointReaction of
//!   the setup are never treated as rigid here (so nothing crossing them is
//!   dropped and their reactions stay those of the full model).
//! - A **muscle** is dropped when every body its path touches (path points,
//!   wrap objects) lies in one rigid cluster and none of its conditional or
//!   moving path points depends on a moving coordinate: its length cannot
//!   change with any free coordinate, so its moment arm on every free row is
//!   exactly zero and its optimal activation in the locked full model is
//!   max(0, min_control). Dropped muscles are absent from the output tables
//!   (not zero-filled); `<name>_<analysis>_reduction.txt` lists them. With
//!   `passive_fiber_forces` muscles are never dropped (their passive force
//!   would still load the joints).
//! - An **actuator** is dropped when it cannot act on a free coordinate: a
//!   CoordinateActuator on a coordinate that does not move, a PointActuator
//!   on a body rigidly attached to ground, a TorqueActuator between two
//!   bodies of one cluster.
//! - A **contact** is skipped when its two bodies lie in one rigid cluster
//!   (its force cannot reach a free row) or its weight w(d) is 0 on every
//!   frame (it never engages); contacts named in `<close_contacts>` are kept.
//!   Either way its optimal multipliers in the locked full model are zero.
//! - A **body** is dropped when its mass cannot enter a free row (every joint
//!   between it and ground is rigid), it carries nothing kept (path points or
//!   wrap objects of a kept muscle, a kept contact or actuator, any passive
//!   force element, an external load, a JointReaction joint or a body in the
//!   subtree of its child) and no kept body descends from it. Passive force
//!   elements are all kept.
//!
//! What is exact: for the free coordinates, the reduced problem is the full
//! problem with the static coordinates locked (same rows, same columns for
//! every kept variable, removed variables having zero columns and hence their
//! trivial optimum). Against the full model *without* locks the answers
//! differ wherever a static coordinate's equation of motion coupled variables
//! (e.g. a locked hip carries the hip moment that hip muscles and the seat
//! contacts carried before).
//!
//! The tool (`tools::reduce::reduce`) opens the motion's states as the run
//! streams them and names the joints of the setup's JointReactions; this
//! stage does the rest (`frame::reduce::reduce`).

use std::collections::HashSet;
use std::fmt::Write as _;
use std::path::Path;

use crate::contacts::Contact;
use crate::dynamics::{kinematics, Data};
use crate::error::Result;
use crate::forces::actuators::{Actuator, ActuatorKind};
use crate::forces::analysis_model::{applies_force, force_kind, AnalysisModel, ForceKind};
use crate::forces::external_loads::ExternalLoads;
use crate::forces::passive::PassiveForce;
use crate::frame::driver::is_frame;
use crate::model::{compile, Model};
use crate::motion::states::assemble;
use crate::motion::stream::StateStream;
use crate::muscles::set::MuscleSet;
use crate::parse::setup::AnalyzeSetup;
use crate::paths::PointKind;
use crate::xml::Element;

/// A coordinate whose value spans less than this over the analysed frames
/// (rad or m), with speed (per s) and target acceleration (per s²) below it,
/// does not move.
pub const STATIC_TOLERANCE: f64 = 1e-9;

/// What a reduction removed.
#[derive(Debug, Clone, Default)]
pub struct Reduction {
    /// Frames scanned.
    pub frames: usize,
    /// Coordinates left as rows of the problem.
    pub free: Vec<String>,
    /// Coordinates locked by the reduction, with their value (rad or m).
    pub locked: Vec<(String, f64)>,
    /// Coordinates removed with their (dropped) bodies; none of them moves.
    pub coordinates_dropped: Vec<String>,
    pub muscles: Vec<String>,
    pub actuators: Vec<String>,
    /// Contacts whose bodies are rigidly joined.
    pub contacts_cannot_act: Vec<String>,
    /// Contacts with w(d) = 0 on every frame.
    pub contacts_never_engaged: Vec<String>,
    pub bodies: Vec<String>,
}

impl Reduction {
    /// One line per category, for the run's warnings.
    pub fn summary_lines(&self) -> Vec<String> {
        let list = |v: &[String]| {
            if v.is_empty() {
                "none".to_string()
            } else {
                v.join(", ")
            }
        };
        let locked: Vec<String> = self.locked.iter().map(|(n, _)| n.clone()).collect();
        vec![
            format!(
                "reduce_model: {} coordinates do not move over {} frames and were locked: {}; free: {}",
                locked.len(),
                self.frames,
                list(&locked),
                list(&self.free)
            ),
            format!(
                "reduce_model: {} muscles and {} actuators cannot act on a free coordinate and were dropped: {}",
                self.muscles.len(),
                self.actuators.len(),
                list(&[self.muscles.clone(), self.actuators.clone()].concat())
            ),
            format!(
                "reduce_model: {} contacts skipped: cannot act on a free coordinate: {}; never engaged: {}",
                self.contacts_cannot_act.len() + self.contacts_never_engaged.len(),
                list(&self.contacts_cannot_act),
                list(&self.contacts_never_engaged)
            ),
            format!(
                "reduce_model: {} bodies dropped: {} (with their coordinates: {})",
                self.bodies.len(),
                list(&self.bodies),
                list(&self.coordinates_dropped)
            ),
        ]
    }

    /// The report file's text.
    pub fn report(&self) -> String {
        let mut s = String::new();
        let _ = writeln!(
            s,
            "statopt reduce_model: what the model lost for this motion ({} frames scanned; tolerance {STATIC_TOLERANCE:e}).\nDropped muscles, actuators and contacts are absent from the output tables.\n",
            self.frames
        );
        let _ = writeln!(s, "[free coordinates] {}", self.free.len());
        for n in &self.free {
            let _ = writeln!(s, "{n}");
        }
        let _ = writeln!(
            s,
            "\n[locked coordinates] {} (value, rad or m)",
            self.locked.len()
        );
        for (n, v) in &self.locked {
            let _ = writeln!(s, "{n}\t{v:.17e}");
        }
        for (title, v) in [
            ("dropped muscles", &self.muscles),
            ("dropped actuators", &self.actuators),
            (
                "skipped contacts (cannot act on a free coordinate)",
                &self.contacts_cannot_act,
            ),
            (
                "skipped contacts (never engaged)",
                &self.contacts_never_engaged,
            ),
            ("dropped bodies", &self.bodies),
            (
                "coordinates dropped with their bodies",
                &self.coordinates_dropped,
            ),
        ] {
            let _ = writeln!(s, "\n[{title}] {}", v.len());
            for n in v {
                let _ = writeln!(s, "{n}");
            }
        }
        s
    }

    pub fn write(&self, path: &Path) -> Result<()> {
        crate::storage::results::write(path, self.report().into_bytes())
    }
}

/// Union-find over bodies.
struct Clusters(Vec<usize>);

impl Clusters {
    fn find(&mut self, mut b: usize) -> usize {
        while self.0[b] != b {
            self.0[b] = self.0[self.0[b]];
            b = self.0[b];
        }
        b
    }
    fn union(&mut self, a: usize, b: usize) {
        let (ra, rb) = (self.find(a), self.find(b));
        self.0[ra] = rb;
    }
    fn same(&mut self, bodies: &[usize]) -> bool {
        let Some(&first) = bodies.first() else {
            return true;
        };
        let r = self.find(first);
        bodies.iter().all(|&b| self.find(b) == r)
    }
}

/// Per coordinate: whether it moves and its value on the first frame; per
/// contact: whether w(d) > 0 on some frame, over the analysed frames of
/// `stream` (the setup's states as the run streams them). Returns the frame
/// count too.
fn scan(
    mut stream: StateStream,
    model: &Model,
    contacts: &[Contact],
    step_interval: usize,
) -> Result<(Vec<bool>, Vec<f64>, Vec<bool>, usize)> {
    let nq = model.nq();
    let (i0, i1) = (stream.first_row, stream.last_row);
    let mut lo = vec![f64::INFINITY; nq];
    let mut hi = vec![f64::NEG_INFINITY; nq];
    let mut rate = vec![0.0f64; nq];
    let mut first: Option<Vec<f64>> = None;
    let mut engaged = vec![false; contacts.len()];
    let mut data = Data::new(model);
    let mut frames = 0;
    while let Some(block) = stream.next_block()? {
        for k in 0..block.time.len() {
            if !is_frame(block.first + k, i0, i1, step_interval) {
                continue;
            }
            frames += 1;
            let (q, u, a) = (&block.q[k], &block.u[k], &block.udot[k]);
            for c in 0..nq {
                lo[c] = lo[c].min(q[c]);
                hi[c] = hi[c].max(q[c]);
                rate[c] = rate[c].max(u[c].abs()).max(a[c].abs());
            }
            if first.is_none() {
                first = Some(q.clone());
            }
            if !contacts.is_empty() {
                data.q.copy_from_slice(q);
                data.u.copy_from_slice(u);
                assemble(model, block.time[k], &mut data.q, &mut data.u);
                data.udot.iter_mut().for_each(|x| *x = 0.0);
                kinematics::full(model, &mut data);
                for (e, c) in engaged.iter_mut().zip(contacts) {
                    if c.state(model, &data).weight > 0.0 {
                        *e = true;
                    }
                }
            }
        }
    }
    let mut moving: Vec<bool> = (0..nq)
        .map(|c| {
            let span = hi[c] - lo[c];
            // A NaN anywhere counts as moving.
            !(span <= STATIC_TOLERANCE && rate[c] <= STATIC_TOLERANCE)
        })
        .collect();
    // Dependent coordinates of moving independent ones move (chains too).
    loop {
        let mut changed = false;
        for cp in &model.couplers {
            if cp.independent.iter().any(|&i| moving[i]) && !moving[cp.dependent] {
                moving[cp.dependent] = true;
                changed = true;
            }
        }
        if !changed {
            break;
        }
    }
    let value = first.unwrap_or_else(|| vec![0.0; nq]);
    Ok((moving, value, engaged, frames))
}

/// The model an AnalyzeTool's static optimization needs for the setup's
/// motion, and what was removed (see the module docs). `open_stream` opens
/// the setup's states on `am.model` as the run streams them (called once,
/// after the model's contacts are compiled); `reaction_joints` gives the
/// joints of the setup's JointReactions, `(joint, expressed-in body)` each
/// (called once, after the scan).
pub fn reduce<'a>(
    setup: &AnalyzeSetup,
    am: &'a AnalysisModel,
    step_interval: usize,
    passive_fiber_forces: bool,
    open_stream: impl FnOnce() -> Result<StateStream<'a>>,
    reaction_joints: impl FnOnce() -> Result<Vec<(usize, usize)>>,
) -> Result<(AnalysisModel, Reduction)> {
    let model = &am.model;
    let nb = model.nbodies();
    let forces: Vec<&Element> = {
        let mut v = Vec::new();
        for f in &am.forces {
            if applies_force(f)? {
                v.push(f);
            }
        }
        v
    };
    let mut contacts: Vec<(&Element, Contact)> = Vec::new();
    for f in forces
        .iter()
        .filter(|f| force_kind(f) == ForceKind::Contact)
    {
        if let Some(c) = Contact::from_xml(f, model)? {
            contacts.push((f, c));
        }
    }
    let contact_list: Vec<Contact> = contacts.iter().map(|(_, c)| c.clone()).collect();
    let (moving, value, engaged, frames) =
        scan(open_stream()?, model, &contact_list, step_interval)?;

    // Joints of JointReactions: never rigid for dropping; their child's
    // subtree and their parent are kept.
    let mut jr_joints: HashSet<usize> = HashSet::new();
    let mut keep = vec![false; nb];
    keep[0] = true;
    for (joint, frame_body) in reaction_joints()? {
        jr_joints.insert(joint);
        keep[model.joints[joint].parent_body] = true;
        keep[frame_body] = true;
        for b in 1..nb {
            if is_descendant(model, b, joint) {
                keep[b] = true;
            }
        }
    }
    let joint_rigid: Vec<bool> = (0..nb)
        .map(|b| {
            let j = &model.joints[b];
            b == 0 || (j.q_start..j.q_start + j.nq).all(|c| !moving[c])
        })
        .collect();
    let mut clusters = Clusters((0..nb).collect());
    for b in 1..nb {
        if joint_rigid[b] && !jr_joints.contains(&b) {
            clusters.union(b, model.joints[b].parent_body);
        }
    }
    // Bodies whose mass enters a free row: below a joint that is not rigid.
    for b in 1..nb {
        let mut x = b;
        while x != 0 {
            if !joint_rigid[x] {
                keep[b] = true;
                break;
            }
            x = model.joints[x].parent_body;
        }
    }

    let mut red = Reduction {
        frames,
        ..Default::default()
    };
    let mut removed: HashSet<*const Element> = HashSet::new();
    // Muscles.
    let owned: Vec<Element> = forces.iter().map(|f| (*f).clone()).collect();
    let muscles = MuscleSet::compile(&am.spec, &owned, model)?;
    for m in &muscles.muscles {
        let path = &m.path;
        let moving_point = path.points.iter().any(|p| match &p.kind {
            PointKind::Fixed => false,
            PointKind::Conditional { coordinate, .. } | PointKind::Moving { coordinate, .. } => {
                moving[*coordinate]
            }
        });
        let mut bodies: Vec<usize> = path.points.iter().map(|p| p.body).collect();
        bodies.extend(
            path.wraps
                .iter()
                .map(|w| muscles.wrap_objects[w.object].body),
        );
        if !passive_fiber_forces && !moving_point && clusters.same(&bodies) {
            red.muscles.push(m.muscle.name.clone());
            removed.insert(forces[m.force_index] as *const Element);
        } else {
            for b in bodies {
                keep[b] = true;
            }
        }
    }
    // Actuators and passive forces.
    for f in &forces {
        match force_kind(f) {
            ForceKind::Actuator => {
                let Some(a) = Actuator::from_xml(f, model)? else {
                    continue;
                };
                let (acts, bodies) = match a.kind {
                    ActuatorKind::Coordinate { coordinate } => {
                        (moving[coordinate], vec![model.coordinates[coordinate].body])
                    }
                    ActuatorKind::Point { body, .. } => (!clusters.same(&[body, 0]), vec![body]),
                    ActuatorKind::Torque { body_a, body_b, .. } => {
                        (!clusters.same(&[body_a, body_b]), vec![body_a, body_b])
                    }
                };
                if acts {
                    for b in bodies {
                        keep[b] = true;
                    }
                } else {
                    red.actuators.push(a.name.clone());
                    removed.insert(*f as *const Element);
                }
            }
            ForceKind::Other => {
                if let Some(p) = PassiveForce::from_xml(f, model)? {
                    match p {
                        PassiveForce::CoordinateLimit { coordinate, .. }
                        | PassiveForce::ExpressionBasedCoordinate { coordinate, .. }
                        | PassiveForce::SpringGeneralized { coordinate, .. } => {
                            keep[model.coordinates[coordinate].body] = true;
                        }
                        PassiveForce::PointToPointSpring { body1, body2, .. } => {
                            keep[body1] = true;
                            keep[body2] = true;
                        }
                    }
                }
            }
            ForceKind::Muscle | ForceKind::Contact => {}
        }
    }
    // Contacts.
    for (k, (f, c)) in contacts.iter().enumerate() {
        let closed = setup.close_contacts.iter().any(|(n, _)| *n == c.name);
        if !closed && clusters.same(&[c.point_body, c.plane_body]) {
            red.contacts_cannot_act.push(c.name.clone());
            removed.insert(*f as *const Element);
        } else if !closed && !engaged[k] {
            red.contacts_never_engaged.push(c.name.clone());
            removed.insert(*f as *const Element);
        } else {
            keep[c.point_body] = true;
            keep[c.plane_body] = true;
        }
    }
    // External loads and close_contacts coordinates.
    if let Some(p) = &setup.external_loads_file {
        let dir = setup.dir();
        let loads = ExternalLoads::load(p, dir, model)?;
        for ef in &loads.forces {
            for b in [
                ef.applied_to_body,
                ef.force_expressed_in,
                ef.point_expressed_in,
            ] {
                keep[b] = true;
            }
        }
    }
    for (_, coordinate) in &setup.close_contacts {
        if let Some(c) = model.coordinate_index(coordinate) {
            keep[model.coordinates[c].body] = true;
        }
    }
    // Ancestors of kept bodies are kept (parents precede children).
    for b in (1..nb).rev() {
        if keep[b] {
            keep[model.joints[b].parent_body] = true;
        }
    }

    // The reduced spec.
    let mut spec = am.spec.clone();
    let dropped_bodies: HashSet<&str> = (1..nb)
        .filter(|&b| !keep[b])
        .map(|b| model.bodies[b].name.as_str())
        .collect();
    red.bodies = (1..nb)
        .filter(|&b| !keep[b])
        .map(|b| model.bodies[b].name.clone())
        .collect();
    let dropped_joints: HashSet<&str> = (1..nb)
        .filter(|&b| !keep[b])
        .map(|b| model.joints[b].name.as_str())
        .collect();
    let dropped_coords: HashSet<String> = (0..model.nq())
        .filter(|&c| !keep[model.coordinates[c].body])
        .map(|c| model.coordinates[c].name.clone())
        .collect();
    red.coordinates_dropped = (0..model.nq())
        .filter(|&c| !keep[model.coordinates[c].body])
        .map(|c| model.coordinates[c].name.clone())
        .collect();
    spec.bodies
        .retain(|b| !dropped_bodies.contains(b.name.as_str()));
    spec.joints
        .retain(|j| !dropped_joints.contains(j.name.as_str()));
    spec.frames.retain(|f| match model.frame(&f.path) {
        Some(fr) if fr.path == f.path => keep[fr.body],
        _ => true,
    });
    spec.wrap_objects
        .retain(|(body, _)| !dropped_bodies.contains(body.as_str()));
    // Couplers: drop those touching a dropped coordinate; a kept dependent of
    // a dropped independent does not move and is locked below.
    let mut lock_dependent: HashSet<String> = HashSet::new();
    spec.couplers.retain(|c| {
        if dropped_coords.contains(&c.dependent) {
            return false;
        }
        if c.independent.iter().any(|i| dropped_coords.contains(i)) {
            lock_dependent.insert(c.dependent.clone());
            return false;
        }
        true
    });
    for j in &mut spec.joints {
        for cs in &mut j.coordinates {
            let Some(c) = model.coordinate_index(&cs.name) else {
                continue;
            };
            let coord = &model.coordinates[c];
            let lockable = !coord.is_constrained() || lock_dependent.contains(&cs.name);
            if lockable && !moving[c] {
                cs.locked = true;
                cs.default_value = value[c];
                cs.free_to_satisfy_constraints = false;
                cs.prescribed = false;
                red.locked.push((cs.name.clone(), value[c]));
            }
        }
    }
    red.free = (0..model.nq())
        .filter(|&c| !model.coordinates[c].is_constrained() && moving[c])
        .map(|c| model.coordinates[c].name.clone())
        .collect();
    let reduced = compile(&spec)?;
    let kept_forces: Vec<Element> = forces
        .iter()
        .filter(|f| !removed.contains(&(**f as *const Element)))
        .map(|f| (*f).clone())
        .collect();
    Ok((
        AnalysisModel {
            model: reduced,
            spec,
            forces: kept_forces,
            warnings: am.warnings.clone(),
        },
        red,
    ))
}

/// Whether body `b` is `root` or below it.
fn is_descendant(model: &Model, mut b: usize, root: usize) -> bool {
    loop {
        if b == root {
            return true;
        }
        match model.bodies[b].parent {
            Some(p) if b != 0 => b = p,
            _ => return false,
        }
    }
}
