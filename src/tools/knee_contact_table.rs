//! The knee contact method's table, `<name>_KneeContact.sto` (per knee:
//! flexion, total, medial and lateral force), and the reactions it is made
//! from: written by static optimization and force sweeps as well as by the
//! `knee-contact` subcommand (`tools::knee_contact`, which documents the
//! columns), so that they need not import the subcommand. The rows are
//! `reactions::knee_contact`'s; `writers::knee_tables` writes the table as
//! the frames stream.

pub use crate::reactions::knee_contact::{labels, reaction_specs, REACTIONS_NAME};

/// Header text of the table.
pub use crate::writers::knee_tables::CONTACT_DESCRIPTION as DESCRIPTION;
