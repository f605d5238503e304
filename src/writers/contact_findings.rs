//! What a run's contacts did that its user must be told: a contact that
//! slid while it was loaded, one that went more than a millimetre into its
//! plane while loaded, one that carried nothing over the whole motion (and
//! why, when the reason is structural: a body held by reserve actuators
//! only), and, for a frame the optimiser could not solve, the contacts that
//! stood at a limit there.
//!
//! Every statement is made from the values the `ContactForces` table holds
//! for the frame (one contact's [`CONTACT_COLUMNS`], read by
//! [`ContactFrame::from_columns`]): the run's table writer hands the same
//! row it writes, a resumed run the rows read back. So the summary names a
//! contact exactly when its own table shows it.
//!
//! Thresholds (stated in docs/contact_model.md, "What the summary says about
//! contacts"):
//! - loaded: more than [`LOADED_FORCE`] = 10 N of contact force, |(fx, fy,
//!   fz)|, about the weight of 1 kg: below it a contact holds no body
//!   segment of a person;
//! - slid: the regime column above 0 (kinetic, or a `regime_blend` share of
//!   it): the shear is then μk N against the slip, not a static hold;
//! - into its plane: the distance column below −[`PENETRATION_LIMIT`] =
//!   −1 mm (the distance is positive on the normal's side, negative inside);
//! - carried nothing: at most [`UNLOADED_FORCE`] = 1 N on every frame, a
//!   tenth of "loaded".

use crate::frame::problem::{Control, SoProblem, CONTACT_COLUMNS};

/// Contact force (N) above which a contact counts as loaded.
pub const LOADED_FORCE: f64 = 10.0;
/// Depth (m) into the plane beyond which a loaded contact is reported.
pub const PENETRATION_LIMIT: f64 = 1e-3;
/// A contact whose force stays at or below this (N) on every frame carried
/// nothing.
pub const UNLOADED_FORCE: f64 = 1.0;

/// One contact at one frame, as its `ContactForces` columns hold it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ContactFrame {
    /// |(fx, fy, fz)| (N).
    pub force: f64,
    /// Signed distance d (m), positive on the normal's side.
    pub distance: f64,
    pub weight: f64,
    pub slip_speed: f64,
    /// β: 0 static, 1 kinetic, between: blended.
    pub regime: f64,
    /// λn, λs1, λs2.
    pub lambda: [f64; 3],
}

impl ContactFrame {
    /// From one contact's values in [`CONTACT_COLUMNS`] order.
    pub fn from_columns(v: &[f64]) -> ContactFrame {
        ContactFrame {
            force: (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt(),
            distance: v[6],
            weight: v[7],
            slip_speed: v[8],
            regime: v[9],
            lambda: [v[10], v[11], v[12]],
        }
    }
    /// More than [`LOADED_FORCE`].
    pub fn loaded(&self) -> bool {
        self.force > LOADED_FORCE
    }
    /// Kinetic, or partly (a blended regime).
    pub fn sliding(&self) -> bool {
        self.regime > 0.0
    }
    /// More than [`PENETRATION_LIMIT`] into the plane.
    pub fn too_deep(&self) -> bool {
        self.distance < -PENETRATION_LIMIT
    }
}

/// What a finding says.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FindingKind {
    /// Slid while loaded: `frames` such frames, `value` the largest slip
    /// speed among them (m/s).
    Slid,
    /// More than 1 mm into its plane while loaded: `frames` such frames,
    /// `value` the deepest distance among them (m, negative).
    TooDeep,
    /// Carried nothing: `frames` the frames it was within reach (w > 0),
    /// `value` the largest force of any frame (N).
    CarriedNothing,
}

impl FindingKind {
    /// Its name in the Python summary.
    pub fn as_str(self) -> &'static str {
        match self {
            FindingKind::Slid => "slid",
            FindingKind::TooDeep => "too_deep",
            FindingKind::CarriedNothing => "carried_nothing",
        }
    }
}

/// A statement about one contact over one run.
#[derive(Debug, Clone, PartialEq)]
pub struct ContactFinding {
    /// The run it is about in a sweep or study (`w0 = 1`), None for a single
    /// run.
    pub run: Option<String>,
    pub contact: String,
    pub kind: FindingKind,
    pub frames: usize,
    pub value: f64,
    /// Time (s) of `value`.
    pub time: f64,
    /// The body held by reserve actuators only that explains a contact that
    /// carried nothing (None: no such reason).
    pub reserve_body: Option<String>,
    /// The summary's line.
    pub message: String,
}

/// Per contact, what the frames so far showed.
#[derive(Debug, Clone, Default)]
struct Tally {
    slid: usize,
    slip_max: (f64, f64),
    deep: usize,
    deepest: (f64, f64),
    force_max: (f64, f64),
    in_reach: usize,
    distance_range: (f64, f64),
}

/// A run's contacts so far (see the module documentation).
#[derive(Debug, Clone, Default)]
pub struct ContactTally {
    tallies: Vec<Tally>,
    /// Per equation row: whether muscles applied a generalized force there
    /// on some frame.
    muscles_acted: Vec<bool>,
    frames: usize,
}

impl ContactTally {
    pub fn new(problem: &SoProblem) -> ContactTally {
        ContactTally {
            tallies: vec![
                Tally {
                    deepest: (f64::INFINITY, 0.0),
                    distance_range: (f64::INFINITY, f64::NEG_INFINITY),
                    ..Default::default()
                };
                problem.contacts.len()
            ],
            muscles_acted: vec![false; problem.rows.len()],
            frames: 0,
        }
    }

    /// Take in one frame: its contact row (the `ContactForces` values) and
    /// its generalized forces by source (4 per row).
    pub fn observe(&mut self, time: f64, contacts: &[f64], by_source: &[f64]) {
        self.frames += 1;
        for (k, acted) in self.muscles_acted.iter_mut().enumerate() {
            if by_source.get(4 * k + 1).is_some_and(|&m| m != 0.0) {
                *acted = true;
            }
        }
        for (t, v) in self
            .tallies
            .iter_mut()
            .zip(contacts.chunks_exact(CONTACT_COLUMNS.len()))
        {
            let f = ContactFrame::from_columns(v);
            if f.force > t.force_max.0 {
                t.force_max = (f.force, time);
            }
            if f.weight > 0.0 {
                t.in_reach += 1;
            }
            t.distance_range.0 = t.distance_range.0.min(f.distance);
            t.distance_range.1 = t.distance_range.1.max(f.distance);
            if f.loaded() && f.sliding() {
                if t.slid == 0 || f.slip_speed > t.slip_max.0 {
                    t.slip_max = (f.slip_speed, time);
                }
                t.slid += 1;
            }
            if f.loaded() && f.too_deep() {
                if f.distance < t.deepest.0 {
                    t.deepest = (f.distance, time);
                }
                t.deep += 1;
            }
        }
    }

    /// The run's findings, contact by contact.
    pub fn findings(&self, problem: &SoProblem) -> Vec<ContactFinding> {
        let n = self.frames;
        let mut out = Vec::new();
        if n == 0 {
            return out;
        }
        let at = crate::storage::fmt_time;
        for (ci, (c, t)) in problem.contacts.iter().zip(&self.tallies).enumerate() {
            let finding = |kind, frames, value, time, message| ContactFinding {
                run: None,
                contact: c.name.clone(),
                kind,
                frames,
                value,
                time,
                reserve_body: None,
                message,
            };
            if t.slid > 0 {
                out.push(finding(
                    FindingKind::Slid,
                    t.slid,
                    t.slip_max.0,
                    t.slip_max.1,
                    format!(
                        "contact {} slid while loaded (more than {LOADED_FORCE} N, kinetic regime) on {} of {n} frames, at up to {} m/s (t={}; its v_trans is {} m/s): its shear there is kinetic friction against the slip, not a static hold",
                        c.name,
                        t.slid,
                        amount(t.slip_max.0),
                        at(t.slip_max.1),
                        amount(c.v_trans)
                    ),
                ));
            }
            if t.deep > 0 {
                out.push(finding(
                    FindingKind::TooDeep,
                    t.deep,
                    t.deepest.0,
                    t.deepest.1,
                    format!(
                        "contact {} was more than {} mm into its plane while loaded (more than {LOADED_FORCE} N) on {} of {n} frames, {:.1} mm deep at most (t={}): the motion puts its point inside the surface; check the kinematics, the point and the plane",
                        c.name,
                        1e3 * PENETRATION_LIMIT,
                        t.deep,
                        -1e3 * t.deepest.0,
                        at(t.deepest.1)
                    ),
                ));
            }
            if t.force_max.0 <= UNLOADED_FORCE {
                let mut f = finding(
                    FindingKind::CarriedNothing,
                    t.in_reach,
                    t.force_max.0,
                    t.force_max.1,
                    String::new(),
                );
                let most = format!(
                    "contact {} carried nothing: at most {} N on any of {n} frames",
                    c.name,
                    amount(t.force_max.0)
                );
                f.message = if t.in_reach == 0 {
                    format!(
                        "{most}; it was out of reach on every frame (w(d) = 0: its distance from the plane was {:.4} to {:.4} m, beyond contact_tolerance + contact_transition_zone = {} m)",
                        t.distance_range.0,
                        t.distance_range.1,
                        c.d_tol + c.d_trans
                    )
                } else if let Some(why) = self.held_by_reserves(problem, ci) {
                    f.reserve_body = Some(why.body.clone());
                    format!(
                        "{most}, though within reach (w(d) > 0) on {} of them. Its body {} moves on {}, where no muscle acted and only {} can hold it: any force on {} would have to be balanced about {} by {}{}, which the objective charges (force/optimal force)², and that is why static optimization left it unloaded (docs/contact_model.md, \"A backrest on a trunk held by reserves\")",
                        t.in_reach,
                        why.body,
                        why.coordinates.join(", "),
                        why.reserves,
                        c.name,
                        if why.coordinates.len() > 1 { "them" } else { "it" },
                        if why.count > 1 { "those reserves" } else { "that reserve" },
                        if why.further.is_empty() {
                            String::new()
                        } else {
                            format!(
                                " (or by the forces of {}, further out, which reach it through joints only reserves hold as well)",
                                why.further.join(", ")
                            )
                        }
                    )
                } else {
                    format!(
                        "{most}, though within reach (w(d) > 0) on {} of them",
                        t.in_reach
                    )
                };
                out.push(f);
            }
        }
        out
    }

    /// Whether contact `ci`'s point body hangs on a joint whose free
    /// coordinates only reserve actuators (CoordinateActuators) hold: no
    /// muscle applied a generalized force there on any frame, no other
    /// actuator acts on the bodies that joint carries, and no other contact
    /// on those bodies carried anything, but for contacts further out
    /// beyond another joint held by reserves only (named). None when any of
    /// that fails (or the joint is a person's root joint, or the plane is on
    /// a body the joint carries too).
    fn held_by_reserves(&self, problem: &SoProblem, ci: usize) -> Option<ReserveHold> {
        let model = &problem.model;
        let c = &problem.contacts[ci];
        // The nearest joint with coordinates, from the point body up.
        let mut body = c.point_body;
        while body != 0 && model.joints[body].nq == 0 {
            body = model.joints[body].parent_body;
        }
        if body == 0 {
            return None;
        }
        let carried = |mut b: usize| loop {
            if b == body {
                return true;
            }
            if b == 0 {
                return false;
            }
            b = model.joints[b].parent_body;
        };
        if carried(c.plane_body) {
            return None;
        }
        let joint = &model.joints[body];
        let coords: Vec<usize> = (joint.q_start..joint.q_start + joint.nq).collect();
        let mut rows = Vec::new();
        for &q in &coords {
            if model.is_root_coordinate(q) {
                return None;
            }
            let k = problem.rows.iter().position(|&r| r == q)?;
            if self.muscles_acted[k] {
                return None;
            }
            rows.push(k);
        }
        // The actuators: CoordinateActuators on these coordinates only.
        let mut reserves = Vec::new();
        for (control, label) in problem.controls.iter().zip(&problem.labels) {
            let Control::Actuator(a) = control else {
                continue;
            };
            use crate::forces::actuators::ActuatorKind;
            match &a.kind {
                ActuatorKind::Coordinate { coordinate } => {
                    if coords.contains(coordinate) {
                        let unit = match model.coordinates[*coordinate].motion_type {
                            crate::model::MotionType::Translational => "N",
                            _ => "N m",
                        };
                        reserves.push(format!(
                            "{label} (optimal force {} {unit})",
                            a.optimal_force
                        ));
                    }
                }
                ActuatorKind::Point { body: b, .. } => {
                    if carried(*b) {
                        return None;
                    }
                }
                ActuatorKind::Torque { body_a, body_b, .. } => {
                    if carried(*body_a) != carried(*body_b) {
                        return None;
                    }
                }
            }
        }
        if reserves.is_empty() {
            return None;
        }
        // Another loaded contact on these bodies could balance the moment
        // too: none may sit on the body itself (or on bodies welded to
        // it); one further out (a hand on a handle) is named, when a joint
        // between it and this body is held by reserves only as well.
        let reserve_only = |q: usize| {
            !model.is_root_coordinate(q)
                && problem
                    .rows
                    .iter()
                    .position(|&r| r == q)
                    .is_some_and(|k| !self.muscles_acted[k])
                && problem.controls.iter().any(|c| {
                    matches!(c, Control::Actuator(a) if matches!(a.kind,
                        crate::forces::actuators::ActuatorKind::Coordinate { coordinate } if coordinate == q))
                })
        };
        let mut further = Vec::new();
        for (k, (other, t)) in problem.contacts.iter().zip(&self.tallies).enumerate() {
            if k == ci
                || carried(other.point_body) == carried(other.plane_body)
                || t.force_max.0 <= UNLOADED_FORCE
            {
                continue;
            }
            let mut b = if carried(other.point_body) {
                other.point_body
            } else {
                other.plane_body
            };
            let mut through_reserves = false;
            while b != body {
                let j = &model.joints[b];
                if j.nq > 0 && (j.q_start..j.q_start + j.nq).all(reserve_only) {
                    through_reserves = true;
                }
                b = j.parent_body;
            }
            if !through_reserves {
                return None;
            }
            further.push(other.name.clone());
        }
        let names: Vec<String> = coords
            .iter()
            .map(|&q| model.coordinates[q].name.clone())
            .collect();
        Some(ReserveHold {
            body: model.bodies[body].name.clone(),
            coordinates: names,
            further,
            count: reserves.len(),
            reserves: format!(
                "the reserve actuator{} {}",
                if reserves.len() > 1 { "s" } else { "" },
                reserves.join(", ")
            ),
        })
    }
}

/// A body held by reserves only: its name, its joint's coordinates and the
/// reserves there.
struct ReserveHold {
    body: String,
    coordinates: Vec<String>,
    /// Loaded contacts further out on the chain, beyond joints held by
    /// reserves only, whose forces also reach these coordinates.
    further: Vec<String>,
    reserves: String,
    count: usize,
}

/// The contacts of an unsolved frame that stood at a limit of their
/// friction model: normal force at zero (λn = 0 within reach), shear on the
/// friction limit, kinetic (shear fixed by the normal force), or out of
/// reach (w = 0). `contacts` is the frame's `ContactForces` row.
pub fn contacts_at_limits(problem: &SoProblem, contacts: &[f64]) -> Vec<String> {
    let mut out = Vec::new();
    for (c, v) in problem
        .contacts
        .iter()
        .zip(contacts.chunks_exact(CONTACT_COLUMNS.len()))
    {
        let f = ContactFrame::from_columns(v);
        let [n, s1, s2] = f.lambda;
        let what = if f.weight <= 0.0 {
            Some("out of reach (w = 0)".to_string())
        } else if n <= 1e-9 {
            Some("normal force at zero".to_string())
        } else if f.regime >= 1.0 {
            Some("kinetic (shear fixed at μk N)".to_string())
        } else {
            // The static limit, (1 − β) μs λn, as the friction model poses it.
            let mu = (1.0 - f.regime) * c.mu_s;
            let sc = crate::optimize::StaticContact {
                normal: 0,
                shear: [1, 2],
                mu,
            };
            let violation = problem.options.friction.violation(&sc, &[n, s1, s2]);
            (violation >= -1e-6 * (mu * n).max(1e-12)).then(|| {
                if f.regime > 0.0 {
                    format!(
                        "shear on the friction limit (blended regime β = {:.2})",
                        f.regime
                    )
                } else {
                    "shear on the friction limit".to_string()
                }
            })
        };
        if let Some(w) = what {
            out.push(format!("{} {w}", c.name));
        }
    }
    out
}

/// A force (N) or speed (m/s) in a line: three decimals, or four significant
/// digits below a thousandth (so that neither 0.000 nor 12 digits is
/// printed).
fn amount(v: f64) -> String {
    if v == 0.0 || v.abs() >= 1e-3 {
        format!("{v:.3}")
    } else {
        format!("{v:.3e}")
    }
}
