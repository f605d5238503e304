//! `statopt-tool motion`: the command's arguments are read in the binary;
//! the motion's profile is `motion::generate` and its table, contacts
//! closed, `contacts::motion::generate`. The old paths re-export them.

pub use crate::contacts::motion::generate;
pub use crate::motion::generate::{
    min_jerk, parse_link, parse_plant, parse_touch, profile, Link, MinJerkMotion,
};
