//! Frictional point-on-plane contact of Krüger & Wartzack (2017), §2.1–2.2.4:
//! a ForceSet element whose three multipliers (λn, λs1, λs2) are unknowns of
//! the per-frame force-sharing problem, like the controls of actuators.
//!
//! - [`element`]: the [`Contact`] element read from XML
//!   (`PointOnPlaneContact`, or the original plugin's `ContactPointOnPlane`);
//! - [`kinematics`]: per-frame geometry ([`ContactState`]: distance, weight
//!   w(d), projection p*, slip velocity, friction regime), the generalized
//!   force of each multiplier, and the contact forces for output;
//! - [`facing`]: contacts whose plane faces away from their point's body
//!   (`--check`);
//! - [`feet`]: foot contact sets built from a model's feet and the motion,
//!   for ground-reaction prediction;
//! - [`ground`]: ground reactions per foot from the contacts' forces and
//!   from measured plates (predict-grf);
//! - [`closure`]: coordinates solved on every row of a motion so that a
//!   contact stays closed (`<close_contacts>`: a machine's lever follows
//!   the pad on the shin);
//! - [`motion`]: a synthetic motion's table with its contacts closed or
//!   planted on every row (`statopt-tool motion`).
pub mod closure;
pub mod element;
pub mod events;
pub mod facing;
pub mod feet;
pub mod floor;
pub mod ground;
pub mod kinematics;
pub mod motion;
pub mod plates;
pub mod targets;
#[cfg(test)]
mod tests;

pub use element::{Contact, CONTACT_TYPE_NAMES};
pub use kinematics::{weight, ContactState, Regime};
