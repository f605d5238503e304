//! Multibody algorithms as plain functions over (`&Model`, `&mut Data`), in
//! the order a frame is processed:
//! [`kinematics`] (poses, velocities, accelerations) → [`rnea`] (inverse
//! dynamics) / [`jacobian`] (station Jacobians) / [`mass_matrix`] →
//! [`forward`] (constrained forward dynamics).

pub mod body_kinematics;
pub mod data;
pub mod forward;
pub mod jacobian;
pub mod kinematics;
pub mod mass_matrix;
pub mod rnea;

pub use data::{BodyForce, Data};
