//! Per-evaluation buffers, kept apart from the immutable [`Model`].

use nalgebra::{Matrix3, Vector3};

use crate::model::joint::JointMotion;
use crate::model::Model;

/// A spatial force on a body: the force and its moment about the ground
/// origin, both expressed in ground (see [`BodyForce::at_point`]).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct BodyForce {
    /// Force, ground frame.
    pub force: Vector3<f64>,
    /// Moment about the ground origin, ground frame.
    pub moment: Vector3<f64>,
}

impl BodyForce {
    /// A force `f` acting at point `p` (both in ground).
    pub fn at_point(f: Vector3<f64>, p: Vector3<f64>) -> Self {
        BodyForce {
            force: f,
            moment: p.cross(&f),
        }
    }
    /// A pure torque (ground frame).
    pub fn torque(t: Vector3<f64>) -> Self {
        BodyForce {
            force: Vector3::zeros(),
            moment: t,
        }
    }
    pub fn add(&mut self, other: &BodyForce) {
        self.force += other.force;
        self.moment += other.moment;
    }
}

/// Workspace for one frame of one model. Allocate once per thread with
/// [`Data::new`]; every algorithm overwrites what it computes.
#[derive(Debug, Clone)]
pub struct Data {
    /// Generalized coordinates, speeds, accelerations (tree order).
    pub q: Vec<f64>,
    pub u: Vec<f64>,
    pub udot: Vec<f64>,
    /// Body orientation (body → ground) and origin position in ground.
    pub rotation: Vec<Matrix3<f64>>,
    pub position: Vec<Vector3<f64>>,
    /// Angular velocity and velocity of the body origin, ground frame.
    pub omega: Vec<Vector3<f64>>,
    pub velocity: Vec<Vector3<f64>>,
    /// Angular acceleration and acceleration of the body origin, ground frame.
    pub alpha: Vec<Vector3<f64>>,
    pub accel: Vec<Vector3<f64>>,
    /// Per joint: motion in F, F's orientation in ground, M's origin in ground.
    pub joint_motion: Vec<JointMotion>,
    pub r_gf: Vec<Matrix3<f64>>,
    pub p_gm: Vec<Vector3<f64>>,
    /// Applied body forces (ground frame, moments about the ground origin).
    pub applied: Vec<BodyForce>,
    /// Applied generalized forces.
    pub applied_gen: Vec<f64>,
    /// Spatial force transmitted by each body's inboard joint to the body's
    /// subtree (force, moment about the ground origin; ground frame), filled by RNEA.
    pub joint_force: Vec<BodyForce>,
    /// RNEA output: generalized forces.
    pub tau: Vec<f64>,
    /// Buffers of constrained forward dynamics (`forward::ForwardBuffers`),
    /// sized on first use.
    pub forward: super::forward::ForwardBuffers,
}

impl Data {
    pub fn new(model: &Model) -> Self {
        let nb = model.nbodies();
        let nq = model.nq();
        Data {
            q: vec![0.0; nq],
            u: vec![0.0; nq],
            udot: vec![0.0; nq],
            rotation: vec![Matrix3::identity(); nb],
            position: vec![Vector3::zeros(); nb],
            omega: vec![Vector3::zeros(); nb],
            velocity: vec![Vector3::zeros(); nb],
            alpha: vec![Vector3::zeros(); nb],
            accel: vec![Vector3::zeros(); nb],
            joint_motion: vec![JointMotion::default(); nb],
            r_gf: vec![Matrix3::identity(); nb],
            p_gm: vec![Vector3::zeros(); nb],
            applied: vec![BodyForce::default(); nb],
            applied_gen: vec![0.0; nq],
            joint_force: vec![BodyForce::default(); nb],
            tau: vec![0.0; nq],
            forward: Default::default(),
        }
    }

    /// Ground position of a station `p` (body frame) on body `b`.
    pub fn station_position(&self, b: usize, p: &Vector3<f64>) -> Vector3<f64> {
        self.position[b] + self.rotation[b] * p
    }

    /// Ground velocity of a station `p` (body frame) on body `b`.
    pub fn station_velocity(&self, b: usize, p: &Vector3<f64>) -> Vector3<f64> {
        self.velocity[b] + self.omega[b].cross(&(self.rotation[b] * p))
    }

    /// Ground acceleration of a station `p` (body frame) on body `b`.
    pub fn station_acceleration(&self, b: usize, p: &Vector3<f64>) -> Vector3<f64> {
        let r = self.rotation[b] * p;
        self.accel[b] + self.alpha[b].cross(&r) + self.omega[b].cross(&self.omega[b].cross(&r))
    }

    /// Clear applied body and generalized forces.
    pub fn clear_applied(&mut self) {
        self.applied
            .iter_mut()
            .for_each(|f| *f = BodyForce::default());
        self.applied_gen.iter_mut().for_each(|f| *f = 0.0);
    }
}
