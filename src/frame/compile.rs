//! Compiling a static-optimization run once ([`SoProblem::build`]): the
//! setup's model and force set sorted into the problem's controls (muscles,
//! actuators, reserves), passive forces, contacts and external loads, in
//! OpenSim's ForceSet order (opensim-semantics.md §6).

use crate::contacts::Contact;
use crate::error::{Error, Location, Result};
use crate::forces::actuators::{Actuator, ActuatorKind};
use crate::forces::analysis_model::{
    applies_force, force_kind, load_analysis_model, AnalysisModel, ForceKind,
};
use crate::forces::external_loads::ExternalLoadsFiles;
use crate::forces::passive::PassiveForce;
use crate::frame::problem::{force_file_row, Control, SoProblem};
use crate::frame::settings::{ConstraintMatrix as ConstraintMatrixKind, StaticOptimizationSetup};
use crate::muscles::set::MuscleSet;
use crate::parse::setup::AnalyzeSetup;
use crate::xml::Element;

/// An unbounded CoordinateActuator, as OpenSim creates for
/// `use_model_force_set = false` (and statopt for reserves).
fn free_coordinate_actuator(name: &str, coordinate: usize, optimal_force: f64) -> Actuator {
    Actuator {
        name: name.to_string(),
        kind: ActuatorKind::Coordinate { coordinate },
        optimal_force,
        min_control: f64::NEG_INFINITY,
        max_control: f64::INFINITY,
        applies_force: true,
        type_name: "CoordinateActuator".into(),
    }
}

impl SoProblem {
    pub fn build(
        setup: &AnalyzeSetup,
        so: &StaticOptimizationSetup,
    ) -> Result<(SoProblem, Vec<String>)> {
        Self::build_beside(setup, so, || ())
    }

    /// [`SoProblem::build`], running `beside` on the external loads'
    /// thread once they are read (e.g. the motion's rows parsed ahead,
    /// `storage::TableFile::parse_rows_ahead`), while the main thread is
    /// still reading the model; `beside` is not run when the setup names no
    /// external loads (no thread is started for it alone).
    pub fn build_beside(
        setup: &AnalyzeSetup,
        so: &StaticOptimizationSetup,
        beside: impl FnOnce() + Send,
    ) -> Result<(SoProblem, Vec<String>)> {
        // The external loads' files are read (and their data splined) on a
        // thread of their own while the model is read and compiled; they are
        // bound to the model where `build_from` reads them, so errors come
        // in the same order.
        let run = crate::storage::results::context();
        let (am, loads) = std::thread::scope(|scope| {
            let run = &run;
            let loads = setup.external_loads_file.as_deref().map(|p| {
                scope.spawn(move || {
                    run.run(|| {
                        let loads = ExternalLoadsFiles::read(p, setup.dir());
                        beside();
                        loads
                    })
                })
            });
            let am = load_analysis_model(setup);
            let loads = loads.map(|h| {
                h.join()
                    .unwrap_or_else(|_| Err(Error::internal("reading the external loads panicked")))
            });
            (am, loads)
        });
        Self::build_with_loads(setup, so, am?, move || loads)
    }

    /// [`SoProblem::build`] on an already loaded model (e.g. a reduced one,
    /// `tools::reduce`).
    pub fn build_from(
        setup: &AnalyzeSetup,
        so: &StaticOptimizationSetup,
        am: AnalysisModel,
    ) -> Result<(SoProblem, Vec<String>)> {
        Self::build_with_loads(setup, so, am, || {
            setup
                .external_loads_file
                .as_deref()
                .map(|p| ExternalLoadsFiles::read(p, setup.dir()))
        })
    }

    /// [`SoProblem::build_from`], the setup's external loads' files read by
    /// `loads` (None: the setup names none) where they are bound.
    fn build_with_loads(
        setup: &AnalyzeSetup,
        so: &StaticOptimizationSetup,
        am: AnalysisModel,
        loads: impl FnOnce() -> Option<Result<ExternalLoadsFiles>>,
    ) -> Result<(SoProblem, Vec<String>)> {
        let model = am.model;
        let mut warnings = am.warnings;
        let mut forces: Vec<Element> = Vec::new();
        for f in am.forces {
            if applies_force(&f)? {
                forces.push(f);
            }
        }
        let rows: Vec<usize> = (0..model.nq())
            .filter(|&c| !model.coordinates[c].is_constrained())
            .collect();
        let mut controls = Vec::new();
        let mut labels = Vec::new();
        let mut lower = Vec::new();
        let mut upper = Vec::new();
        let mut passive = Vec::new();
        let mut passive_after = Vec::new();
        let mut contacts: Vec<Contact> = Vec::new();
        let muscles = if !so.use_model_force_set {
            // OpenSim: a CoordinateActuator "<coord>_actuator" (optimal force 1)
            // per unconstrained coordinate, then the non-muscle forces.
            for &c in &rows {
                let name = format!("{}_actuator", model.coordinates[c].name);
                controls.push(Control::Actuator(free_coordinate_actuator(&name, c, 1.0)));
                labels.push(name);
                lower.push(f64::NEG_INFINITY);
                upper.push(f64::INFINITY);
            }
            forces.retain(|f| force_kind(f) != ForceKind::Muscle);
            MuscleSet::compile(&am.spec, &[], &model)?
        } else {
            MuscleSet::compile(&am.spec, &forces, &model)?
        };
        let mut next_muscle = 0;
        for f in &forces {
            match force_kind(f) {
                ForceKind::Muscle => {
                    let m = &muscles.muscles[next_muscle];
                    controls.push(Control::Muscle(next_muscle));
                    labels.push(m.muscle.name.clone());
                    lower.push(m.muscle.params.min_control);
                    upper.push(m.muscle.params.max_control);
                    next_muscle += 1;
                }
                ForceKind::Actuator => {
                    let a =
                        Actuator::from_xml(f, &model)?.ok_or_else(|| f.error("not an actuator"))?;
                    labels.push(a.name.clone());
                    lower.push(a.min_control);
                    upper.push(a.max_control);
                    controls.push(Control::Actuator(a));
                }
                ForceKind::Contact => {
                    if let Some(c) = Contact::from_xml(f, &model)? {
                        if c.mu_k > c.mu_s {
                            warnings.push(format!(
                                "{}: kinetic_friction {} exceeds static_friction {}; Coulomb's law allows it, but sliding usually needs less force than breaking away: check the two values",
                                f.loc(),
                                c.mu_k,
                                c.mu_s
                            ));
                        }
                        if contacts.iter().any(|x: &Contact| x.name == c.name) {
                            return Err(f.error(format!("two contacts are named '{}'", c.name)));
                        }
                        contacts.push(c);
                    }
                }
                ForceKind::Other => match PassiveForce::from_xml(f, &model)? {
                    Some(p) => {
                        passive_after.push(controls.len());
                        passive.push(p);
                    }
                    None => {
                        return Err(f.error(format!(
                            "force type '{}' is not supported by statopt's static optimization",
                            f.name
                        )))
                    }
                },
            }
        }
        if let Some(opt) = so.reserve_actuators {
            for &c in &rows {
                let name = format!("{}_reserve", model.coordinates[c].name);
                if labels.contains(&name) {
                    return Err(Error::input(
                        Location::file(&setup.setup_file),
                        format!("reserve_actuators: the model already has a force named '{name}'"),
                    ));
                }
                controls.push(Control::Actuator(free_coordinate_actuator(&name, c, opt)));
                // Reserve columns follow the ForceSet in both files.
                labels.push(name);
                lower.push(f64::NEG_INFINITY);
                upper.push(f64::INFINITY);
            }
        }
        if controls.len() + 3 * contacts.len() < rows.len() {
            return Err(Error::input(
                Location::file(&setup.model_file),
                format!(
                    "over-constrained: {} actuators and {} contact multipliers for {} unconstrained coordinates",
                    controls.len(),
                    3 * contacts.len(),
                    rows.len()
                ),
            ));
        }
        let loads = match loads() {
            Some(files) => {
                let mut l = files?.bind(&model)?;
                l.scale(&setup.external_load_scales)?;
                Some(l)
            }
            None => None,
        };
        let passive_labels: Vec<String> = passive.iter().flat_map(|p| p.record_labels()).collect();
        let passive_sizes: Vec<usize> = passive.iter().map(PassiveForce::record_size).collect();
        let mut force_labels =
            force_file_row(&labels, &passive_labels, &passive_sizes, &passive_after);
        if let Some(l) = &loads {
            for ef in &l.forces {
                force_labels.extend(ef.labels.iter().cloned());
            }
        }
        let knees = crate::frame::knee_contact::select(
            &model,
            &so.knee_contact,
            so.knee_contact_frontal,
            so.knee_contact_capacity_bw,
            so.knee_contact_medial_share,
        )
        .map_err(|e| Error::msg(format!("{}: {e}", setup.setup_file.display())))?;
        if !knees.is_empty() && so.constraint_matrix == ConstraintMatrixKind::Perturbation {
            return Err(Error::msg(format!(
                "{}: knee_contact needs <constraint_matrix>analytic</constraint_matrix> (its rows are the knee reaction at the target accelerations)",
                setup.setup_file.display()
            )));
        }
        let ties = crate::frame::knee_contact::equal_activation_pairs(
            &labels,
            &knees,
            &so.knee_contact_equal_activation,
        )
        .map_err(
            |e| match so.element.child("knee_contact_equal_activation") {
                Some(c) => c.error(e.to_string()),
                None => Error::msg(format!("{}: {e}", setup.setup_file.display())),
            },
        )?;
        let targets = crate::contacts::targets::groups(&contacts)?;
        if so.activation_exponent != 2.0 {
            warnings.push(format!(
                "activation_exponent {} is solved with power cones",
                so.activation_exponent
            ));
        }
        Ok((
            SoProblem {
                model,
                muscles,
                controls,
                labels,
                lower,
                upper,
                passive,
                passive_after,
                loads,
                rows,
                options: crate::frame::options::SoOptions::compile(so),
                force_labels,
                contacts,
                ties,
                knees,
                targets,
            },
            warnings,
        ))
    }
}
