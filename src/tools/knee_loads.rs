//! Knee loads as a user of a knee study reads them (issue 15): from a
//! joint-reaction table, per side, the knee flexion angle, tibiofemoral
//! compression and shear, and patellofemoral compression, written as
//! `<reaction table prefix>KneeLoads.sto`.
//!
//! **Frame and signs.** The tibiofemoral load is the reaction of the knee
//! joint (the joint whose child is `tibia_<s>`) *on the tibia*, in the tibia
//! body frame (the JointReaction must report it with `apply_on_bodies`
//! child and `express_in_frame` child):
//! - `tf_compression_<s>` = −F_y: along the tibia's long axis (its y axis,
//!   ankle→knee in the gait2392 and Rajagopal models), positive when the
//!   femur presses the tibia distally. The tibial plateau is not normal to
//!   that axis (it slopes posteriorly by several degrees), so this is the
//!   axial component, not the plateau-normal one.
//! - `tf_shear_<s>` = +F_x: perpendicular to the long axis, in the tibia's
//!   sagittal plane (its x axis, anterior). A positive value is the joint
//!   pushing the tibia anteriorly, i.e. holding it against a *posterior*
//!   drawer, the load the posterior cruciate ligament carries: **PCL-type
//!   positive, ACL-type negative** (Escamilla et al. 1998's convention).
//! - `pf_compression_<s>` = |F| of the reaction of the patellofemoral joint
//!   (the joint whose child is `patella_<s>`) on the patella: the force
//!   between femur and patella. Absent for a model without patella bodies
//!   (gait2392: its quadriceps pull on the tibia directly).
//! - `knee_flexion_<s>`: the angle (degrees) between the femur's and the
//!   tibia's long axes (their y axes) in the femur's sagittal plane,
//!   positive in flexion, whatever sign convention the model's knee
//!   coordinate has (gait2392: negative in flexion; Rajagopal: positive).
//!
//! The rows are computed by `reactions::knee_loads` from each frame's
//! reactions; `writers::knee_tables` writes the table as the frames
//! stream.
pub use crate::reactions::knee_loads::{flexion_degrees, knee_row, labels, sides, Side};

/// Header text of the table.
pub use crate::writers::knee_tables::LOADS_DESCRIPTION as DESCRIPTION;
