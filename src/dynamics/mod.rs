//! Multibody algorithms as plain functions over (`&Model`, `&mut Data`), in
//! the order a frame is processed:
//! [`kinematics`] (poses, velocities, accelerations) → [`rnea`] (inverse
//! dynamics) / [`jacobian`] (station Jacobians) / [`mass_matrix`].

pub mod data;
pub mod jacobian;
pub mod kinematics;
pub mod mass_matrix;
pub mod rnea;

pub use data::{BodyForce, Data};
