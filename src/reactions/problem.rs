//! A JointReaction run compiled once ([`JointReactionProblem::build`]: the
//! model's actuators, passive forces and external loads, the forces file's
//! columns, the reactions asked for) and one frame's reactions
//! ([`JointReactionProblem::frame`], opensim-semantics.md §7).

use crate::error::{Error, Location, Result};
use crate::forces::actuators::Actuator;
use crate::forces::analysis_model::{
    applies_force, force_kind, load_analysis_model, AnalysisModel, ForceKind,
};
use crate::forces::external_loads::ExternalLoads;
use crate::forces::passive::PassiveForce;
use crate::frame::problem::Control;
use crate::frame::workspace::Workspace;
use crate::model::Model;
use crate::motion::states::assemble;
use crate::motion::stream::{FrameSource, StateBlock};
use crate::muscles::set::MuscleSet;
use crate::parse::setup::AnalyzeSetup;
use crate::reactions::forces_file::ForcesFile;
use crate::reactions::joint::{apply_forces, reactions, ReactionSpec};
use crate::reactions::setup::{resolve_reactions, JointReactionSetup};
use crate::storage;

/// Everything a JointReaction frame needs, compiled once.
pub struct JointReactionProblem {
    pub model: Model,
    pub muscles: MuscleSet,
    /// Actuators that apply force, in ForceSet order.
    pub controls: Vec<Control>,
    pub passive: Vec<PassiveForce>,
    pub loads: Option<ExternalLoads>,
    /// The forces file and, per control, its data column.
    pub forces: ForcesFile,
    pub columns: Vec<usize>,
    pub specs: Vec<ReactionSpec>,
}

impl JointReactionProblem {
    pub fn build(
        setup: &AnalyzeSetup,
        jr: &JointReactionSetup,
    ) -> Result<(JointReactionProblem, Vec<String>)> {
        Self::build_from(setup, jr, load_analysis_model(setup)?)
    }

    /// [`build`](Self::build) on an already loaded model (the run's, when
    /// several analyses share it: `tools::analyze`).
    pub fn build_from(
        setup: &AnalyzeSetup,
        jr: &JointReactionSetup,
        am: AnalysisModel,
    ) -> Result<(JointReactionProblem, Vec<String>)> {
        let model = am.model;
        let mut warnings = am.warnings;
        let mut forces = Vec::new();
        for f in am.forces {
            if applies_force(&f)? {
                forces.push(f);
            }
        }
        let muscles = MuscleSet::compile(&am.spec, &forces, &model)?;
        let mut controls = Vec::new();
        let mut names = Vec::new();
        let mut passive = Vec::new();
        let mut next_muscle = 0;
        for f in &forces {
            match force_kind(f) {
                ForceKind::Muscle => {
                    names.push(muscles.muscles[next_muscle].muscle.name.clone());
                    controls.push(Control::Muscle(next_muscle));
                    next_muscle += 1;
                }
                ForceKind::Actuator => {
                    let a =
                        Actuator::from_xml(f, &model)?.ok_or_else(|| f.error("not an actuator"))?;
                    names.push(a.name.clone());
                    controls.push(Control::Actuator(a));
                }
                ForceKind::Contact => {
                    return Err(f.error("contact elements in joint reactions are not supported yet"))
                }
                ForceKind::Other => match PassiveForce::from_xml(f, &model)? {
                    Some(p) => passive.push(p),
                    None => {
                        return Err(f.error(format!(
                            "force type '{}' is not supported by statopt's joint reaction analysis",
                            f.name
                        )))
                    }
                },
            }
        }
        let el = &jr.element;
        let (forces, columns) = if controls.is_empty() {
            (ForcesFile::none(), Vec::new())
        } else {
            let Some(file) = &jr.forces_file else {
                return Err(el.error(format!(
                    "JointReaction '{}' has no <forces_file>, but the model has {} actuators ({}); give the actuator forces (e.g. a static optimization force file). OpenSim would silently use default muscle states here.",
                    jr.common.name,
                    names.len(),
                    names.join(", ")
                )));
            };
            let context =
                |e: Error| e.context(format!("forces_file of JointReaction '{}'", jr.common.name));
            // One pass over the rows (all read, none kept): their errors
            // before the run, and the row count.
            let mut pass = storage::open_rows(file).map_err(context)?;
            let mut rows = 0usize;
            let mut row = Vec::new();
            while pass.next_row(&mut row).map_err(context)?.is_some() {
                rows += 1;
            }
            let table = pass.table.clone();
            let missing: Vec<&str> = names
                .iter()
                .filter(|n| table.column_index(n).is_none())
                .map(String::as_str)
                .collect();
            if !missing.is_empty() {
                return Err(Error::input(
                    Location::file(file),
                    format!(
                        "the forces file of JointReaction '{}' lacks the actuator(s) {}; every actuator of the model needs a column (OpenSim would silently fall back to forces computed from default states)",
                        jr.common.name,
                        missing.join(", ")
                    ),
                ));
            }
            if rows == 0 {
                return Err(Error::input(
                    Location::file(file),
                    "the forces file has no rows",
                ));
            }
            let columns: Vec<usize> = names
                .iter()
                .map(|n| table.column_index(n).unwrap_or(0))
                .collect();
            let beyond: Vec<&str> = names
                .iter()
                .zip(&columns)
                .filter(|(_, &c)| c >= names.len())
                .map(|(n, _)| n.as_str())
                .collect();
            if !beyond.is_empty() {
                warnings.push(format!(
                    "{}: the columns of {} lie beyond the first {} data columns; statopt reads them by name, OpenSim would read unfilled values",
                    file.display(),
                    beyond.join(", "),
                    names.len()
                ));
            }
            (ForcesFile::streamed(file, table), columns)
        };
        let setup_dir = setup.dir();
        let loads = match &setup.external_loads_file {
            Some(p) => {
                let mut l = ExternalLoads::load(p, setup_dir, &model)?;
                l.scale(&setup.external_load_scales)?;
                Some(l)
            }
            None => None,
        };
        let (specs, w) = resolve_reactions(&model, jr)?;
        warnings.extend(w);
        Ok((
            JointReactionProblem {
                model,
                muscles,
                controls,
                passive,
                loads,
                forces,
                columns,
                specs,
            },
            warnings,
        ))
    }

    /// One frame's row (9 values per reported joint).
    pub fn frame(&self, t: f64, q: &[f64], u: &[f64], ws: &mut Workspace) -> Result<Vec<f64>> {
        let model = &self.model;
        let (data, mf) = (&mut ws.data, &mut ws.muscles);
        data.q.copy_from_slice(q);
        data.u.copy_from_slice(u);
        assemble(model, t, &mut data.q, &mut data.u);
        let values = if self.columns.is_empty() {
            Vec::new()
        } else {
            self.forces.values_at(t, &self.columns)?
        };
        apply_forces(
            model,
            data,
            mf,
            &self.muscles,
            &self.controls,
            &values,
            &self.passive,
            self.loads.as_ref(),
            t,
        );
        let mut out = vec![0.0; 9 * self.specs.len()];
        reactions(model, data, t, &self.specs, &mut out)?;
        Ok(out)
    }
}

/// The states' blocks, the forces file's window moved to each block's
/// times before its frames are computed.
pub struct WithForces<'a, S> {
    pub inner: &'a mut S,
    pub forces: &'a ForcesFile,
}

impl<S: FrameSource> FrameSource for WithForces<'_, S> {
    fn next_block(&mut self) -> Result<Option<StateBlock>> {
        let block = self.inner.next_block()?;
        if let Some(b) = &block {
            if let (Some(&first), Some(&last)) = (b.time.first(), b.time.last()) {
                self.forces.prepare(first, last)?;
            }
        }
        Ok(block)
    }
}
