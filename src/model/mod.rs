//! The compiled, immutable model: flat, index-ordered arrays built once from a
//! [`ModelSpec`](crate::parse::osim::ModelSpec). Per-evaluation buffers live
//! in [`crate::dynamics::Data`].
//!
//! Index conventions (those of OpenSim/Simbody):
//! - `bodies[0]` is ground; the other bodies follow in multibody-tree order
//!   (by tree level, then by joint order in the file), so a parent always
//!   precedes its children.
//! - `joints[b]` is the joint whose child is body `b` (`joints[0]` is unused).
//! - coordinates are in multibody-tree order: this is the order of q, u and
//!   of OpenSim's inverse-dynamics output columns.

mod compile;
pub mod joint;
pub mod load;

pub use compile::compile;
pub use joint::{JointKind, TransformAxis};

use nalgebra::{Matrix3, Vector3};

use crate::functions::Function;

/// A rigid transform: `x_parent = rotation * x_child + translation`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Transform {
    pub rotation: Matrix3<f64>,
    pub translation: Vector3<f64>,
}

impl Transform {
    pub fn identity() -> Self {
        Transform {
            rotation: Matrix3::identity(),
            translation: Vector3::zeros(),
        }
    }
    /// `self * other`: other's child frame expressed in self's parent frame.
    pub fn compose(&self, other: &Transform) -> Transform {
        Transform {
            rotation: self.rotation * other.rotation,
            translation: self.translation + self.rotation * other.translation,
        }
    }
    pub fn inverse(&self) -> Transform {
        let rt = self.rotation.transpose();
        Transform {
            rotation: rt,
            translation: -(rt * self.translation),
        }
    }
    pub fn apply(&self, x: &Vector3<f64>) -> Vector3<f64> {
        self.rotation * x + self.translation
    }
}

/// Rotation of body-fixed X-Y-Z Euler angles: Rx(a)·Ry(b)·Rz(c) (OpenSim's
/// `orientation` and `xyz_body_rotation` convention, opensim-semantics.md §2.3).
pub fn body_fixed_xyz(angles: &Vector3<f64>) -> Matrix3<f64> {
    rot_x(angles[0]) * rot_y(angles[1]) * rot_z(angles[2])
}

pub fn rot_x(a: f64) -> Matrix3<f64> {
    let (s, c) = a.sin_cos();
    Matrix3::new(1.0, 0.0, 0.0, 0.0, c, -s, 0.0, s, c)
}
pub fn rot_y(a: f64) -> Matrix3<f64> {
    let (s, c) = a.sin_cos();
    Matrix3::new(c, 0.0, s, 0.0, 1.0, 0.0, -s, 0.0, c)
}
pub fn rot_z(a: f64) -> Matrix3<f64> {
    let (s, c) = a.sin_cos();
    Matrix3::new(c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0)
}

#[derive(Debug, Clone)]
pub struct Body {
    pub name: String,
    pub mass: f64,
    pub mass_center: Vector3<f64>,
    /// Inertia about the mass center, body axes.
    pub inertia: Matrix3<f64>,
    /// Parent body index (None for ground).
    pub parent: Option<usize>,
}

#[derive(Debug, Clone)]
pub struct Joint {
    pub name: String,
    pub kind: JointKind,
    pub parent_body: usize,
    pub child_body: usize,
    /// The joint's parent frame F in the parent body.
    pub x_pf: Transform,
    /// The joint's child frame M in the child body.
    pub x_bm: Transform,
    /// First q/u index and count.
    pub q_start: usize,
    pub nq: usize,
    /// Names of the parent and child frames (for output labels).
    pub parent_frame_name: String,
    pub child_frame_name: String,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MotionType {
    Rotational,
    Translational,
    Coupled,
}

#[derive(Debug, Clone)]
pub struct Coordinate {
    pub name: String,
    /// Body whose inboard joint owns this coordinate.
    pub body: usize,
    pub motion_type: MotionType,
    pub default_value: f64,
    pub default_speed: f64,
    pub range: [f64; 2],
    pub clamped: bool,
    pub locked: bool,
    /// Some(f) when prescribed with a function of time.
    pub prescribed: Option<Function>,
    /// Dependent coordinate of an enforced CoordinateCouplerConstraint (or
    /// `is_free_to_satisfy_constraints`).
    pub dependent: bool,
}

impl Coordinate {
    /// OpenSim's `isConstrained`: locked, prescribed or dependent (§2.5).
    pub fn is_constrained(&self) -> bool {
        self.locked || self.prescribed.is_some() || self.dependent
    }
}

/// `q_dep = scale * f(q_indep...)`.
#[derive(Debug, Clone)]
pub struct Coupler {
    pub name: String,
    pub function: Function,
    pub independent: Vec<usize>,
    pub dependent: usize,
    pub scale: f64,
}

/// A named frame fixed on a body (bodies themselves, offset frames).
#[derive(Debug, Clone)]
pub struct Frame {
    pub path: String,
    pub name: String,
    pub body: usize,
    /// Frame in its body.
    pub transform: Transform,
}

#[derive(Debug, Clone)]
pub struct Model {
    pub name: String,
    pub file: std::path::PathBuf,
    pub gravity: Vector3<f64>,
    pub bodies: Vec<Body>,
    /// `joints[b]` mobilizes body `b`; `joints[0]` is a placeholder for ground.
    pub joints: Vec<Joint>,
    pub coordinates: Vec<Coordinate>,
    /// Coordinate indices in the model's CoordinateSet order (joint order in
    /// the file, then order within the joint).
    pub coordinate_set_order: Vec<usize>,
    /// Joint indices (body indices) in the file's JointSet order.
    pub joint_set_order: Vec<usize>,
    pub frames: Vec<Frame>,
    pub couplers: Vec<Coupler>,
    pub warnings: Vec<String>,
}

impl Model {
    pub fn nq(&self) -> usize {
        self.coordinates.len()
    }
    pub fn nbodies(&self) -> usize {
        self.bodies.len()
    }
    pub fn body_index(&self, name: &str) -> Option<usize> {
        self.bodies.iter().position(|b| b.name == name)
    }
    /// Whether coordinate `c` belongs to a root joint: a joint on ground
    /// with three or more coordinates (a person's pelvis), not a one-axis
    /// machine joint. Residual actuators act there.
    pub fn is_root_coordinate(&self, c: usize) -> bool {
        let b = self.coordinates[c].body;
        let j = &self.joints[b];
        j.parent_body == 0 && j.nq >= 3
    }
    /// Mass of body `b` and of every body carried by it (kg).
    pub fn subtree_mass(&self, b: usize) -> f64 {
        (0..self.bodies.len())
            .filter(|&k| {
                let mut at = Some(k);
                while let Some(i) = at {
                    if i == b {
                        return true;
                    }
                    at = self.bodies[i].parent;
                }
                false
            })
            .map(|k| self.bodies[k].mass)
            .sum()
    }
    /// The deepest body that carries both `a` and `b` (ground is 0, the
    /// common ancestor of everything; a body carries itself).
    pub fn common_ancestor(&self, a: usize, b: usize) -> usize {
        let depth = |mut k: usize| {
            let mut d = 0;
            while k != 0 {
                k = self.joints[k].parent_body;
                d += 1;
            }
            d
        };
        let (mut a, mut b) = (a, b);
        let (mut da, mut db) = (depth(a), depth(b));
        while da > db {
            a = self.joints[a].parent_body;
            da -= 1;
        }
        while db > da {
            b = self.joints[b].parent_body;
            db -= 1;
        }
        while a != b {
            a = self.joints[a].parent_body;
            b = self.joints[b].parent_body;
        }
        a
    }
    pub fn coordinate_index(&self, name: &str) -> Option<usize> {
        self.coordinates.iter().position(|c| c.name == name)
    }
    pub fn joint_index(&self, name: &str) -> Option<usize> {
        self.joints
            .iter()
            .skip(1)
            .position(|j| j.name == name)
            .map(|i| i + 1)
    }
    pub fn frame(&self, path_or_name: &str) -> Option<&Frame> {
        self.frames
            .iter()
            .find(|f| f.path == path_or_name)
            .or_else(|| self.frames.iter().find(|f| f.name == path_or_name))
    }
    pub fn total_mass(&self) -> f64 {
        self.bodies.iter().map(|b| b.mass).sum()
    }
}
