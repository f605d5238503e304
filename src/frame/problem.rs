//! One frame of static optimization: the run's compiled problem
//! ([`SoProblem`]: model, muscles, controls, passive forces, external loads,
//! contacts) turned, at a frame's state, into the convex program of
//! `optimize` — kinematics → muscle paths and strength → contact states →
//! the equations of motion as A x = b with bounds and friction cones — and
//! its solution into the frame's outputs ([`FrameResult`]).
//!
//! The equations are written in force space and reduced to the independent,
//! unconstrained coordinates with the coupling vectors C_k:
//! `C_kᵀ Σ_i x_i f_i g_i = C_kᵀ τ_required`, which is OpenSim's
//! acceleration-level constraint `u̇_I(x) = u̇_target` multiplied by the
//! (constraint-reduced) mass matrix. A frame is solved from a cold start, or
//! ([`SoProblem::solve_frame_into`] with `warm`) from the previous frame's
//! multipliers when the frame driver says it follows that frame in a fixed
//! group ([`crate::frame::driver::for_each_frame_grouped`]), so results do
//! not depend on how frames are spread over threads or on where a resumed
//! run starts.

use nalgebra::{DMatrix, DVector};

use crate::contacts::{Contact, ContactState, Regime};
use crate::dynamics::{kinematics, rnea, Data};
use crate::forces::actuators::Actuator;
use crate::forces::external_loads::ExternalLoads;
use crate::forces::passive::PassiveForce;
use crate::frame::options::SoOptions;
use crate::frame::perturbation::Perturbation;
use crate::frame::settings::{ConstraintMatrix, DEFAULT_TOLERANCE};
use crate::model::Model;
use crate::motion::states::assemble;
use crate::muscles::set::{MuscleFrame, MuscleSet};
use crate::optimize::{
    self, FrameProblem, FrameSolution, SolveSettings, SolveStatus, StaticContact,
};
use crate::paths::coupling;

/// One optimisation variable: a muscle (index into the MuscleSet) or another actuator.
#[derive(Debug, Clone)]
pub enum Control {
    Muscle(usize),
    Actuator(Actuator),
}

/// Everything a frame needs, compiled once.
pub struct SoProblem {
    pub model: Model,
    pub muscles: MuscleSet,
    /// Variables in ForceSet order (the activation file's columns).
    pub controls: Vec<Control>,
    pub labels: Vec<String>,
    pub lower: Vec<f64>,
    pub upper: Vec<f64>,
    pub passive: Vec<PassiveForce>,
    /// For each passive force, how many controls precede it in ForceSet
    /// order: where its record columns stand in the force file.
    pub passive_after: Vec<usize>,
    pub loads: Option<ExternalLoads>,
    /// Independent, unconstrained coordinates: the equations' rows.
    pub rows: Vec<usize>,
    /// The numbers the run is solved with, compiled from the plan's
    /// StaticOptimization (`frame::options`); the plan itself is not kept.
    pub options: SoOptions,
    /// Labels of the force file: ForceSet record labels in ForceSet order
    /// (see [`force_file_row`]), reserves, then external forces.
    pub force_labels: Vec<String>,
    /// Point-on-plane contacts; three multipliers each follow the controls.
    pub contacts: Vec<Contact>,
    /// Knees solved with the knee contact method (`<knee_contact>`, empty
    /// for plain static optimization): two multipliers each follow the
    /// contacts', two rows each follow the coordinates' (`frame::knee_contact`).
    pub knees: Vec<crate::frame::knee_contact::Knee>,
    /// Pairs of controls held at equal activation, one row `x_i − x_j = 0`
    /// each after the knee rows: the heads of one muscle under the knee
    /// contact method (`frame::knee_contact::equal_activation_pairs`).
    pub ties: Vec<[usize; 2]>,
    /// Group force targets of the contacts (`force_target_*`,
    /// `contacts::targets`): one row and one free variable per axis of each
    /// group, the rows after the ties', the variables after the knees'.
    pub targets: Vec<crate::contacts::targets::ForceTarget>,
}

/// The ForceSet part of a force-file row (labels or values): each control's
/// entry, with the record entries of passive force `j` (`passive_sizes[j]` of
/// them, concatenated in `passive`) placed after the first
/// `passive_after[j]` controls, i.e. where the force stands in the ForceSet,
/// as OpenSim's ForceReporter orders them. Controls added after the ForceSet
/// (reserves) come last.
pub fn force_file_row<T: Clone>(
    controls: &[T],
    passive: &[T],
    passive_sizes: &[usize],
    passive_after: &[usize],
) -> Vec<T> {
    let mut row = Vec::with_capacity(controls.len() + passive.len());
    force_file_row_into(
        controls,
        passive,
        passive_sizes.iter().copied(),
        passive_after,
        &mut row,
    );
    row
}

/// [`force_file_row`] appended to `row`.
pub fn force_file_row_into<T: Clone>(
    controls: &[T],
    passive: &[T],
    passive_sizes: impl Iterator<Item = usize>,
    passive_after: &[usize],
    row: &mut Vec<T>,
) {
    let mut next_control = 0;
    let mut next_passive = 0;
    for (size, &after) in passive_sizes.zip(passive_after) {
        row.extend_from_slice(&controls[next_control..after]);
        next_control = after;
        row.extend_from_slice(&passive[next_passive..next_passive + size]);
        next_passive += size;
    }
    row.extend_from_slice(&controls[next_control..]);
}

/// Result of one frame.
#[derive(Debug, Clone, Default)]
pub struct FrameResult {
    pub time: f64,
    pub solution: FrameSolution,
    /// Actuator forces (x_i · f_i), same order as the controls.
    pub forces: Vec<f64>,
    /// The force file row.
    pub force_row: Vec<f64>,
    /// max |A x − b| relative to the largest |b| (1 when b = 0).
    pub relative_residual: f64,
    /// Largest friction-constraint violation over static contacts (≤ 0 when met).
    pub friction_violation: f64,
    /// Per free coordinate: required generalized force, and the parts supplied
    /// by muscles, other actuators and contacts.
    pub by_source: Vec<f64>,
    /// Per muscle: mechanical power (W), positive when shortening under tension.
    pub muscle_power: Vec<f64>,
    /// The frame's assembled coordinates, speeds and accelerations (tree order).
    pub q: Vec<f64>,
    pub u: Vec<f64>,
    pub udot: Vec<f64>,
    pub contacts: ContactRows,
}

/// Per-frame contact outputs, one row for each contact table.
#[derive(Debug, Clone, Default)]
pub struct ContactRows {
    /// Per contact: force on the point body (ground), point, distance,
    /// w(d), slip speed, regime β (0 static, 1 kinetic, between: blended), multipliers.
    pub contact: Vec<f64>,
    /// Per body touched by a contact: force (ground) and moment about the
    /// body origin (ground).
    pub bodies: Vec<f64>,
    /// ExternalLoads data: per contact, force and point on the point body,
    /// then (plane body not ground) force and point on the plane body.
    pub loads: Vec<f64>,
}

/// Column suffixes of the contact table.
pub const CONTACT_COLUMNS: [&str; 13] = [
    "fx",
    "fy",
    "fz",
    "px",
    "py",
    "pz",
    "distance",
    "weight",
    "slip_speed",
    "regime",
    "lambda_n",
    "lambda_s1",
    "lambda_s2",
];

/// The buffers one frame's problem is assembled in ([`SoProblem::assemble`]),
/// kept in the per-thread [`Workspace`](crate::frame::Workspace) and reused
/// from frame to frame.
#[derive(Debug, Clone)]
pub struct Assembly {
    /// The frame's convex program.
    pub problem: FrameProblem,
    /// Each variable's force scale f_i.
    pub scale: Vec<f64>,
    /// The passive forces' record values.
    pub passive: Vec<f64>,
    /// Contact states, one per contact.
    pub states: Vec<ContactState>,
    /// The external loads' force-table values (`ExternalLoads::apply_recording`).
    pub external: Vec<f64>,
    /// Per equation row: the coupling vector C_k (coordinate, coefficient).
    pub(crate) couplings: Vec<Vec<(usize, f64)>>,
    g: Vec<f64>,
    cols: [Vec<f64>; 3],
    /// The outputs' working buffers ([`SoProblem::frame_result_into`]).
    scratch: ResultScratch,
    /// The knee rows' buffers (`frame::knee_contact`).
    knee: crate::frame::knee_contact::KneeScratch,
}

/// Buffers of a frame's outputs: generalized forces by source, before and
/// after M_r, and the bodies contacts touch.
#[derive(Debug, Clone, Default)]
struct ResultScratch {
    parts: [DVector<f64>; 4],
    product: DVector<f64>,
    bodies: Vec<usize>,
}

impl Default for Assembly {
    /// Empty buffers, sized by the first [`SoProblem::assemble`].
    fn default() -> Self {
        Assembly {
            problem: FrameProblem {
                a: DMatrix::zeros(0, 0),
                b: DVector::zeros(0),
                weights: Vec::new(),
                exponent: 2.0,
                lower: Vec::new(),
                upper: Vec::new(),
                static_contacts: Vec::new(),
                friction: Default::default(),
                settings: SolveSettings {
                    tolerance: DEFAULT_TOLERANCE,
                    max_iter: 100,
                    solver: Default::default(),
                },
            },
            scale: Vec::new(),
            passive: Vec::new(),
            states: Vec::new(),
            external: Vec::new(),
            couplings: Vec::new(),
            g: Vec::new(),
            cols: Default::default(),
            scratch: Default::default(),
            knee: Default::default(),
        }
    }
}

impl SoProblem {
    /// Build one frame's optimisation problem: returns the problem, each
    /// variable's force scale (f_i) and the passive forces' record values.
    pub fn frame_problem(
        &self,
        t: f64,
        q: &[f64],
        u: &[f64],
        udot_target: &[f64],
        data: &mut Data,
        mf: &mut MuscleFrame,
    ) -> (FrameProblem, Vec<f64>, Vec<f64>, Vec<ContactState>) {
        let (p, scale, passive, states, _) =
            self.frame_problem_scaled(t, q, u, udot_target, data, mf);
        (p, scale, passive, states)
    }

    /// As [`frame_problem`](Self::frame_problem), with the matrix that turns
    /// a row residual into generalized forces on the free coordinates: None
    /// for the analytic rows (already forces), the constraint-reduced mass
    /// matrix M_r = Cᵀ M C for the perturbation rows (accelerations).
    pub fn frame_problem_scaled(
        &self,
        t: f64,
        q: &[f64],
        u: &[f64],
        udot_target: &[f64],
        data: &mut Data,
        mf: &mut MuscleFrame,
    ) -> (
        FrameProblem,
        Vec<f64>,
        Vec<f64>,
        Vec<ContactState>,
        Option<DMatrix<f64>>,
    ) {
        let mut asm = Assembly::default();
        let m_r = self.assemble(t, q, u, udot_target, data, mf, &mut asm);
        let Assembly {
            problem,
            scale,
            passive,
            states,
            ..
        } = asm;
        (problem, scale, passive, states, m_r)
    }

    /// Assemble the frame's problem into `asm`, reusing its buffers: with the
    /// same `asm` from frame to frame, the analytic rows allocate nothing
    /// beyond the passive forces' records. Returns M_r for perturbation rows.
    #[allow(clippy::too_many_arguments)]
    pub fn assemble(
        &self,
        t: f64,
        q: &[f64],
        u: &[f64],
        udot_target: &[f64],
        data: &mut Data,
        mf: &mut MuscleFrame,
        asm: &mut Assembly,
    ) -> Option<DMatrix<f64>> {
        let model = &self.model;
        let nq = model.nq();
        data.q.copy_from_slice(q);
        data.u.copy_from_slice(u);
        assemble(model, t, &mut data.q, &mut data.u);
        // Accelerations: targets for the unconstrained coordinates; the
        // constrained ones follow from their constraints.
        data.udot.copy_from_slice(udot_target);
        crate::dynamics::forward::complete_accelerations(
            model,
            &data.q,
            &data.u,
            t,
            &mut data.udot,
        );
        kinematics::full(model, data);
        data.clear_applied();
        asm.external.clear();
        if let Some(l) = &self.loads {
            l.apply_recording(t, data, &mut asm.external);
        }
        let Assembly {
            problem,
            scale,
            passive: passive_values,
            states,
            external: _,
            couplings,
            g,
            cols,
            scratch: _,
            knee,
        } = asm;
        passive_values.clear();
        g.clear();
        g.resize(nq, 0.0);
        self.add_passive_forces(t, data, g, Some(passive_values));
        mf.evaluate(&self.muscles, model, data);
        self.add_passive_fiber_forces(data, mf);
        let perturb = self.options.constraint_matrix == ConstraintMatrix::Perturbation;
        if !perturb {
            rnea::inverse_dynamics_after_kinematics(model, data, true);
        }
        // Rows: C_kᵀ τ_required = C_kᵀ Σ x_i f_i g_i.
        let nr = self.rows.len();
        let nv = self.controls.len();
        let nc = self.contacts.len();
        // The knee contact method's rows and variables follow (two each per knee).
        let nk = self.knees.len();
        let nt = self.ties.len();
        let ng: usize = self.targets.iter().map(|g| g.rows()).sum();
        let nrt = nr + 2 * nk + nt + ng;
        let a = &mut problem.a;
        // Every column is written below, whole: no need to clear them.
        if a.shape() != (nrt, nv + 3 * nc + 2 * nk + ng) {
            *a = DMatrix::zeros(nrt, nv + 3 * nc + 2 * nk + ng);
        }
        let b = &mut problem.b;
        if b.len() != nrt {
            *b = DVector::zeros(nrt);
        } else {
            b.fill(0.0);
        }
        couplings.resize_with(nr, Vec::new);
        for (cv, &k) in couplings.iter_mut().zip(&self.rows) {
            coupling::coupling_vector_into(model, &data.q, k, cv);
        }
        // Perturbation rows: u̇_I(x) = u̇_target,I by forward dynamics.
        let fd = perturb.then(|| Perturbation::start(self, t, data, mf, couplings));
        if let Some(fd) = &fd {
            for (r, &k) in self.rows.iter().enumerate() {
                b[r] = fd.target[k] - fd.udot0[r];
            }
        } else {
            for (r, cv) in couplings.iter().enumerate() {
                b[r] = cv.iter().map(|(i, c)| c * data.tau[*i]).sum();
            }
        }
        scale.clear();
        scale.resize(nv, 0.0);
        for (v, ctl) in self.controls.iter().enumerate() {
            let (f, gen): (f64, &[f64]) = match ctl {
                Control::Muscle(m) => {
                    let pm = &self.muscles.muscles[*m];
                    let f = if self.options.use_muscle_physiology {
                        mf.max_active_force[*m]
                    } else {
                        pm.muscle.params.max_isometric_force
                    };
                    (f, &mf.unit_force[*m])
                }
                Control::Actuator(act) => {
                    g.iter_mut().for_each(|x| *x = 0.0);
                    act.add_unit_generalized_force(model, data, g);
                    (act.optimal_force, g)
                }
            };
            scale[v] = f;
            if let Some(fd) = &fd {
                let col = fd.column(self, t, data, mf, gen, f);
                a.view_mut((0, v), (nr, 1)).copy_from(&col);
                continue;
            }
            let column = &mut a.as_mut_slice()[v * nrt..v * nrt + nr];
            for (e, cv) in column.iter_mut().zip(couplings.iter()) {
                *e = f * cv.iter().map(|(i, c)| c * gen[*i]).sum::<f64>();
            }
        }
        // Contacts (Krüger & Wartzack eqs. 1-3, 10, 15-16): three multipliers
        // each, weighted 1/w0; static regime: free shear inside the friction
        // cone; kinetic regime: the shear follows the normal force (eq. 3)
        // and the shear multipliers are held at zero.
        problem.lower.clear();
        problem.lower.extend_from_slice(&self.lower);
        problem.upper.clear();
        problem.upper.extend_from_slice(&self.upper);
        problem.weights.clear();
        problem.weights.resize(nv, 1.0);
        problem.static_contacts.clear();
        states.clear();
        for col in cols.iter_mut() {
            col.resize(nq, 0.0);
        }
        for (ci, c) in self.contacts.iter().enumerate() {
            let mut st = c.state(model, data);
            if c.is_held_at(t) {
                c.hold(&mut st);
            }
            if c.is_off_at(t) {
                st.weight *= c.off_weight;
            }
            st.weight *= c.time_factor(t);
            let v0 = nv + 3 * ci;
            cols.iter_mut()
                .for_each(|col| col.iter_mut().for_each(|x| *x = 0.0));
            let kinetic = st.regime == Regime::Kinetic;
            if kinetic {
                c.add_kinetic_normal_column(model, data, &st, &mut cols[0]);
            } else {
                c.add_unit_generalized_forces(model, data, &st, cols);
            }
            for (k, col) in cols.iter().enumerate() {
                if let Some(fd) = &fd {
                    let column = fd.column(self, t, data, mf, col, 1.0);
                    a.view_mut((0, v0 + k), (nr, 1)).copy_from(&column);
                    continue;
                }
                let column = &mut a.as_mut_slice()[(v0 + k) * nrt..(v0 + k) * nrt + nr];
                for (e, cv) in column.iter_mut().zip(couplings.iter()) {
                    *e = cv.iter().map(|(i, cc)| cc * col[*i]).sum::<f64>();
                }
            }
            let shear = if kinetic {
                (0.0, 0.0)
            } else {
                (f64::NEG_INFINITY, f64::INFINITY)
            };
            problem.lower.extend([0.0, shear.0, shear.0]);
            problem.upper.extend([f64::INFINITY, shear.1, shear.1]);
            problem.weights.extend([1.0 / self.w0(); 3]);
            if !kinetic {
                problem.static_contacts.push(StaticContact {
                    normal: v0,
                    shear: [v0 + 1, v0 + 2],
                    mu: c.static_limit(&st),
                });
            }
            states.push(st);
        }
        if nk > 0 {
            problem.lower.extend(std::iter::repeat_n(0.0, 2 * nk));
            problem
                .upper
                .extend(std::iter::repeat_n(f64::INFINITY, 2 * nk));
            problem.weights.extend(std::iter::repeat_n(1.0, 2 * nk));
            self.knee_rows(
                data,
                mf,
                states,
                scale,
                &mut problem.a,
                &mut problem.b,
                nr,
                nv + 3 * nc,
                knee,
            );
        }
        // Heads of one muscle at one activation: rows x_i − x_j = 0, written
        // whole (A is not cleared between frames).
        let ncol = problem.a.ncols();
        for (ti, [i, j]) in self.ties.iter().enumerate() {
            let r = nr + 2 * nk + ti;
            for c in 0..ncol {
                problem.a[(r, c)] = 0.0;
            }
            problem.a[(r, *i)] = 1.0;
            problem.a[(r, *j)] = -1.0;
            problem.b[r] = 0.0;
        }
        if ng > 0 {
            self.target_rows(t, states, problem, nr + 2 * nk + nt, nv + 3 * nc + 2 * nk);
        }
        problem.exponent = self.options.activation_exponent;
        problem.friction = self.options.friction;
        problem.settings = self.options.solve;
        fd.map(|fd| fd.finish(model, data))
    }

    /// The group force targets' rows (from row `r0`) and free variables
    /// (from column `v0`), written whole (A is not cleared between frames):
    /// per row of a group, Σ_c Σ_k (a(t) · f_ck) λ_ck − S x = target(t),
    /// f_ck the force on contact c's point body of its multiplier k at unit
    /// value in the frame's regime; outside the target's span the row is
    /// −S x = 0 (`contacts::targets`). The variables are free, weighted 1.
    fn target_rows(
        &self,
        t: f64,
        states: &[crate::contacts::ContactState],
        problem: &mut FrameProblem,
        r0: usize,
        v0: usize,
    ) {
        let ncol = problem.a.ncols();
        let nv = self.controls.len();
        let mut r = r0;
        for g in &self.targets {
            let value = g.spec.value_at(t);
            for ai in 0..g.rows() {
                for c in 0..ncol {
                    problem.a[(r, c)] = 0.0;
                }
                let v = v0 + (r - r0);
                problem.a[(r, v)] = -g.spec.optimal_force[ai];
                problem.b[r] = 0.0;
                if let Some(value) = &value {
                    let (axis, f) = value[ai];
                    problem.b[r] = f;
                    for &ci in &g.contacts {
                        let (c, st) = (&self.contacts[ci], &states[ci]);
                        let kinetic = st.regime == Regime::Kinetic;
                        for k in 0..3 {
                            let mut lambda = [0.0; 3];
                            lambda[k] = 1.0;
                            let (f, _, _) = c.forces(st, lambda, kinetic);
                            problem.a[(r, nv + 3 * ci + k)] = axis.dot(&f);
                        }
                    }
                }
                r += 1;
            }
        }
        let ng = r - r0;
        problem
            .lower
            .extend(std::iter::repeat_n(f64::NEG_INFINITY, ng));
        problem.upper.extend(std::iter::repeat_n(f64::INFINITY, ng));
        problem.weights.extend(std::iter::repeat_n(1.0, ng));
    }

    /// Adds the passive force elements' generalized forces to
    /// `data.applied_gen` (`g`: scratch of nq entries), appending their
    /// record values to `record` when given.
    pub(crate) fn add_passive_forces(
        &self,
        t: f64,
        data: &mut Data,
        g: &mut [f64],
        mut record: Option<&mut Vec<f64>>,
    ) {
        for p in &self.passive {
            g.iter_mut().for_each(|x| *x = 0.0);
            p.add_generalized_force(&self.model, data, t, g);
            for (a, gk) in data.applied_gen.iter_mut().zip(g.iter()) {
                *a += gk;
            }
            if let Some(r) = record.as_deref_mut() {
                p.record_values_into(data, t, r);
            }
        }
    }

    /// Adds the muscles' passive fiber forces (rigid tendon) to
    /// `data.applied_gen` when the setup asks for them.
    pub(crate) fn add_passive_fiber_forces(&self, data: &mut Data, mf: &MuscleFrame) {
        if self.options.passive_fiber_forces {
            for (f, fp) in mf.unit_force.iter().zip(&mf.passive_force) {
                for (a, fk) in data.applied_gen.iter_mut().zip(f) {
                    *a += fp * fk;
                }
            }
        }
    }

    /// Bodies that receive contact forces, in body order.
    pub fn contact_bodies(&self) -> Vec<usize> {
        let mut b = Vec::new();
        self.contact_bodies_into(&mut b);
        b
    }

    /// [`contact_bodies`](Self::contact_bodies) into `b` (cleared first).
    fn contact_bodies_into(&self, b: &mut Vec<usize>) {
        b.clear();
        b.extend(
            self.contacts
                .iter()
                .flat_map(|c| [c.point_body, c.plane_body]),
        );
        b.sort_unstable();
        b.dedup();
    }

    /// Columns of the generalized-forces-by-source table.
    pub fn by_source_labels(&self) -> Vec<String> {
        self.rows
            .iter()
            .flat_map(|&c| {
                ["required", "muscles", "actuators", "contacts"]
                    .map(|s| format!("{}_{s}", self.model.coordinates[c].name))
            })
            .collect()
    }

    pub fn muscle_labels(&self) -> Vec<String> {
        self.controls
            .iter()
            .filter_map(|c| match c {
                Control::Muscle(m) => Some(self.muscles.muscles[*m].muscle.name.clone()),
                Control::Actuator(_) => None,
            })
            .collect()
    }

    pub fn contact_labels(&self) -> Vec<String> {
        self.contacts
            .iter()
            .flat_map(|c| {
                CONTACT_COLUMNS
                    .iter()
                    .map(move |s| format!("{}_{s}", c.name))
            })
            .collect()
    }

    pub fn contact_body_labels(&self) -> Vec<String> {
        self.contact_bodies()
            .iter()
            .flat_map(|&b| {
                ["Fx", "Fy", "Fz", "Mx", "My", "Mz"]
                    .map(|s| format!("{}_{s}", self.model.bodies[b].name))
            })
            .collect()
    }

    /// The ExternalForces of the exported loads: (name, body, identifier prefix).
    pub fn contact_load_forces(&self) -> Vec<(String, usize, String)> {
        let mut v = Vec::new();
        for c in &self.contacts {
            v.push((
                format!("{}_on_{}", c.name, self.model.bodies[c.point_body].name),
                c.point_body,
                format!("{}_point_", c.name),
            ));
            if c.plane_body != 0 {
                v.push((
                    format!("{}_on_{}", c.name, self.model.bodies[c.plane_body].name),
                    c.plane_body,
                    format!("{}_plane_", c.name),
                ));
            }
        }
        v
    }

    /// A frame's contact rows into `rows` (its buffers reused); `bodies`
    /// is a buffer for the bodies contacts touch.
    fn contact_outputs_into(
        &self,
        states: &[ContactState],
        lambda: &[f64],
        data: &Data,
        bodies: &mut Vec<usize>,
        rows: &mut ContactRows,
    ) {
        self.contact_bodies_into(bodies);
        rows.contact.clear();
        rows.loads.clear();
        rows.bodies.clear();
        rows.bodies.resize(6 * bodies.len(), 0.0);
        let sums = &mut rows.bodies;
        let mut add = |b: usize, f: &nalgebra::Vector3<f64>, p: &nalgebra::Vector3<f64>| {
            let k = bodies.iter().position(|&x| x == b).unwrap_or(0);
            let m = (p - data.position[b]).cross(f);
            for i in 0..3 {
                sums[6 * k + i] += f[i];
                sums[6 * k + 3 + i] += m[i];
            }
        };
        for (ci, (c, st)) in self.contacts.iter().zip(states).enumerate() {
            let l = [lambda[3 * ci], lambda[3 * ci + 1], lambda[3 * ci + 2]];
            let kinetic = st.regime == Regime::Kinetic;
            let (f_point, p, f_plane) = c.forces(st, l, kinetic);
            rows.contact.extend(f_point.iter());
            rows.contact.extend(p.iter());
            rows.contact.extend([
                st.distance,
                st.weight,
                st.slip_speed,
                st.beta,
                l[0],
                l[1],
                l[2],
            ]);
            add(c.point_body, &f_point, &p);
            add(c.plane_body, &f_plane, &st.projection_ground);
            rows.loads.extend(f_point.iter());
            rows.loads.extend(p.iter());
            if c.plane_body != 0 {
                rows.loads.extend(f_plane.iter());
                rows.loads.extend(st.projection_ground.iter());
            }
        }
    }

    /// The contact weight a single frame problem is assembled with: the
    /// run's first (`options.contact_weights`, compiled from the plan; a
    /// sweep solves each of its weights from that one assembly,
    /// `solve_frame_weights`).
    pub fn w0(&self) -> f64 {
        self.options.contact_weights[0]
    }

    /// Solve one frame. `data` and `mf` are per-thread workspaces.
    pub fn solve_frame(
        &self,
        t: f64,
        q: &[f64],
        u: &[f64],
        udot_target: &[f64],
        data: &mut Data,
        mf: &mut MuscleFrame,
    ) -> FrameResult {
        self.solve_frame_weights(t, q, u, udot_target, data, mf, &[self.w0()])
            .pop()
            .expect("one result per weight")
    }

    /// Solve one frame once for each contact weight w0 in `weights`: the
    /// physics (kinematics, muscle paths and strength, contact geometry,
    /// the equations of motion) is assembled once, and only the contacts'
    /// objective weights 1/w0 change between the solves. With the run's own
    /// w0 the result equals [`solve_frame`](Self::solve_frame)'s bit for bit.
    #[allow(clippy::too_many_arguments)]
    pub fn solve_frame_weights(
        &self,
        t: f64,
        q: &[f64],
        u: &[f64],
        udot_target: &[f64],
        data: &mut Data,
        mf: &mut MuscleFrame,
        weights: &[f64],
    ) -> Vec<FrameResult> {
        let mut asm = Assembly::default();
        let mut out = vec![FrameResult::default(); weights.len()];
        self.solve_weights_in(
            t,
            q,
            u,
            udot_target,
            data,
            mf,
            &mut asm,
            weights,
            out.iter_mut(),
            None,
        );
        out
    }

    /// [`solve_frame_weights`](Self::solve_frame_weights) in a per-thread
    /// workspace: the frame is assembled in its buffers, and its kinematics
    /// and muscle paths stay there for the frame's joint reactions.
    pub fn solve_frame_in(
        &self,
        t: f64,
        q: &[f64],
        u: &[f64],
        udot_target: &[f64],
        ws: &mut crate::frame::Workspace,
        weights: &[f64],
    ) -> Vec<FrameResult> {
        let mut out = vec![FrameResult::default(); weights.len()];
        self.solve_frame_into(t, q, u, udot_target, ws, weights, out.iter_mut(), false);
        out
    }

    /// [`solve_frame_in`](Self::solve_frame_in) into `out` (one result per
    /// weight, in order; extra results are left alone), whose buffers are
    /// reused: with the dual Newton solver a frame allocates nothing once
    /// the workspace and the results have their sizes (tests/allocations.rs).
    /// With `warm`, each weight's problem is warm-started from the
    /// multipliers the workspace kept from the last frame it solved with
    /// that weight (`Workspace::warm`; cold when there are none); the
    /// answers differ from cold ones by rounding only, but the caller must
    /// make that previous frame a fixed one (the frame driver's groups) for
    /// results to be reproducible. The multipliers are kept either way.
    #[allow(clippy::too_many_arguments)]
    pub fn solve_frame_into<'r>(
        &self,
        t: f64,
        q: &[f64],
        u: &[f64],
        udot_target: &[f64],
        ws: &mut crate::frame::Workspace,
        weights: &[f64],
        out: impl IntoIterator<Item = &'r mut FrameResult>,
        warm: bool,
    ) {
        let crate::frame::Workspace {
            data,
            muscles,
            assembly,
            warm: multipliers,
        } = ws;
        if multipliers.len() != weights.len() {
            multipliers.resize_with(weights.len(), Vec::new);
        }
        self.solve_weights_in(
            t,
            q,
            u,
            udot_target,
            data,
            muscles,
            assembly,
            weights,
            out,
            Some((multipliers, warm)),
        )
    }

    #[allow(clippy::too_many_arguments)]
    fn solve_weights_in<'r>(
        &self,
        t: f64,
        q: &[f64],
        u: &[f64],
        udot_target: &[f64],
        data: &mut Data,
        mf: &mut MuscleFrame,
        asm: &mut Assembly,
        weights: &[f64],
        out: impl IntoIterator<Item = &'r mut FrameResult>,
        // Per weight, the multipliers kept from the previous frame, and
        // whether to start from them.
        mut warm: Option<(&mut [Vec<f64>], bool)>,
    ) {
        let m_r = self.assemble(t, q, u, udot_target, data, mf, asm);
        let nv = self.controls.len();
        for (k, (&w0, result)) in weights.iter().zip(out).enumerate() {
            // The contact multipliers follow the controls (the knee
            // compartments after them keep their weight 1).
            let nc3 = 3 * self.contacts.len();
            asm.problem.weights[nv..nv + nc3]
                .iter_mut()
                .for_each(|w| *w = 1.0 / w0);
            let y0 = match &warm {
                Some((kept, true)) if !kept[k].is_empty() => Some(kept[k].as_slice()),
                _ => None,
            };
            optimize::solve_into(&asm.problem, y0, &mut result.solution);
            if let Some((kept, _)) = warm.as_mut() {
                kept[k].clear();
                kept[k].extend_from_slice(&result.solution.y);
            }
            self.frame_result_into(t, asm, m_r.as_ref(), data, mf, result);
        }
    }

    /// The outputs of the frame problem in `asm`, solved in
    /// `out.solution`, into `out` (its buffers reused).
    pub(crate) fn frame_result_into(
        &self,
        t: f64,
        asm: &mut Assembly,
        m_r: Option<&DMatrix<f64>>,
        data: &Data,
        mf: &MuscleFrame,
        out: &mut FrameResult,
    ) {
        self.frame_outputs_into(t, asm, m_r, data, mf, Outputs::ALL, out);
    }

    /// [`frame_result_into`](Self::frame_result_into) making only the
    /// outputs `want` names (the others are left as they were); the
    /// forces, residual and friction violation are always made.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn frame_outputs_into(
        &self,
        t: f64,
        asm: &mut Assembly,
        m_r: Option<&DMatrix<f64>>,
        data: &Data,
        mf: &MuscleFrame,
        want: Outputs,
        out: &mut FrameResult,
    ) {
        let Assembly {
            problem,
            scale,
            passive: passive_values,
            states,
            external,
            scratch,
            ..
        } = asm;
        let solution = &out.solution;
        let bmax = problem.b.amax();
        out.relative_residual = if bmax > 0.0 {
            solution.eq_residual / bmax
        } else {
            solution.eq_residual
        };
        let nv = self.controls.len();
        out.forces.clear();
        out.forces.extend(
            solution.x[..nv]
                .iter()
                .zip(scale.iter())
                .map(|(x, f)| x * f),
        );
        out.friction_violation = problem
            .static_contacts
            .iter()
            .map(|c| self.options.friction.violation(c, &solution.x))
            .fold(0.0, f64::max);
        out.time = t;
        if want.contacts {
            self.contact_outputs_into(
                states,
                &solution.x[nv..],
                data,
                &mut scratch.bodies,
                &mut out.contacts,
            );
        }
        if want.by_source {
            self.by_source_into(problem, &solution.x, m_r, scratch, &mut out.by_source);
        }
        if want.muscle_power {
            // Mechanical power of each muscle: tension x shortening speed.
            out.muscle_power.clear();
            out.muscle_power
                .extend(
                    self.controls
                        .iter()
                        .zip(&out.forces)
                        .filter_map(|(c, f)| match c {
                            Control::Muscle(m) => Some(-f * mf.speed[*m]),
                            Control::Actuator(_) => None,
                        }),
                );
        }
        if want.force_row {
            out.force_row.clear();
            force_file_row_into(
                &out.forces,
                passive_values,
                self.passive.iter().map(|p| p.record_size()),
                &self.passive_after,
                &mut out.force_row,
            );
            out.force_row.extend_from_slice(external);
        }
        if want.state {
            out.q.clone_from(&data.q);
            out.u.clone_from(&data.u);
            out.udot.clone_from(&data.udot);
        }
    }

    /// Generalized forces by source on each free coordinate (reduced
    /// rows), of the solution `x` of `problem`, into `by_source`.
    fn by_source_into(
        &self,
        problem: &FrameProblem,
        x: &[f64],
        m_r: Option<&DMatrix<f64>>,
        scratch: &mut ResultScratch,
        by_source: &mut Vec<f64>,
    ) {
        // Generalized forces by source on each free coordinate (reduced rows):
        // required, muscles, other actuators, contacts. Perturbation rows are
        // accelerations: M_r turns them into generalized forces.
        let nr = self.rows.len();
        let parts = &mut scratch.parts;
        for p in parts.iter_mut() {
            if p.len() != nr {
                *p = DVector::zeros(nr);
            } else {
                p.fill(0.0);
            }
        }
        // (The knee contact method's rows, after the coordinates', are not
        // generalized forces.)
        parts[0].copy_from(&problem.b.rows(0, nr));
        for v in 0..problem.a.ncols() {
            let k = match self.controls.get(v) {
                Some(Control::Muscle(_)) => 1,
                Some(Control::Actuator(_)) => 2,
                None => 3,
            };
            parts[k].axpy(x[v], &problem.a.column(v).rows(0, nr), 1.0);
        }
        if let Some(m) = m_r {
            let product = &mut scratch.product;
            if product.len() != nr {
                *product = DVector::zeros(nr);
            }
            for p in parts.iter_mut() {
                product.gemv(1.0, m, p, 0.0);
                p.copy_from(product);
            }
        }
        by_source.clear();
        for r in 0..nr {
            by_source.extend(parts.iter().map(|p| p[r]));
        }
    }
}

/// Which of a [`FrameResult`]'s outputs to make
/// ([`SoProblem::solve_candidate_into`]: a force sweep's metrics read a
/// few of them); the forces, the solution's diagnostics, the relative
/// residual and the friction violation are always made.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Outputs {
    /// The contact tables' rows (`FrameResult::contacts`).
    pub contacts: bool,
    /// The generalized forces by source.
    pub by_source: bool,
    /// The muscles' power.
    pub muscle_power: bool,
    /// The force table's row.
    pub force_row: bool,
    /// The frame's q, u, u̇.
    pub state: bool,
}

impl Outputs {
    /// Every output (a run's frame).
    pub const ALL: Outputs = Outputs {
        contacts: true,
        by_source: true,
        muscle_power: true,
        force_row: true,
        state: true,
    };
    /// None but those always made.
    pub const NONE: Outputs = Outputs {
        contacts: false,
        by_source: false,
        muscle_power: false,
        force_row: false,
        state: false,
    };
}

/// Status code written to the diagnostics table.
pub fn status_code(s: SolveStatus) -> f64 {
    match s {
        SolveStatus::Solved => 0.0,
        SolveStatus::AlmostSolved => 1.0,
        _ => -1.0,
    }
}
