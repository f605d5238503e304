//! A study's `<ForceSweep>` element as a typed value: the AnalyzeTool
//! setup it sweeps (read once), its candidates (each at every w0) and
//! their names, with the element's place for messages. Its unknown
//! children and attributes are found with the study's other elements
//! (`parse::known::study_elements`); here they are skipped.

use std::path::PathBuf;

use crate::error::{Location, Result};
use crate::parse::setup::{resolve, AnalyzeSetup, Setup};
use crate::xml::Element;

/// One candidate of a force sweep, by name: what it changes in the setup.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct CandidateSpec {
    /// The contact weight w0.
    pub w0: f64,
    /// (force name, Lepton expression) of `ExpressionBasedCoordinateForce`s.
    pub expressions: Vec<(String, String)>,
    /// (actuator name, optimal force) of actuators other than muscles.
    pub optimal_forces: Vec<(String, f64)>,
    /// (ExternalForce name, or `*` for every external load, factor): the
    /// load's force and torque data scaled by the factor (factors of one
    /// load multiply).
    pub external_scales: Vec<(String, f64)>,
}

/// A `<ForceSweep name="..." setup="...">` of a study document.
#[derive(Debug, Clone)]
pub struct ForceSweepPlan {
    /// The `name` attribute (`force_sweep` when absent): its table is
    /// `<name>_force_sweep.csv`.
    pub name: String,
    /// The swept setup's file, resolved against the study's folder.
    pub setup_file: PathBuf,
    pub setup: AnalyzeSetup,
    /// Every candidate at every w0, with its name.
    pub specs: Vec<CandidateSpec>,
    pub names: Vec<String>,
    /// `<write_tables>true</write_tables>`: each candidate's tables are
    /// written too (default: metrics only).
    pub write_tables: bool,
    /// Where the element stands.
    pub loc: Location,
}

impl ForceSweepPlan {
    /// Read a `<ForceSweep>` element (`dir`: the study's folder) and the
    /// setup it names (`allow_unknown` as for the study's own setups).
    pub fn from_element(el: &Element, dir: &std::path::Path, allow_unknown: bool) -> Result<Self> {
        let file = el.attr("setup").ok_or_else(|| {
            el.error("a ForceSweep needs a setup attribute (an AnalyzeTool setup file)")
        })?;
        let path = resolve(dir, file);
        let Setup::Analyze(setup) = Setup::read_with(&path, allow_unknown)? else {
            return Err(el.error(format!("setup=\"{file}\" is not an AnalyzeTool setup")));
        };
        let w0s: Vec<f64> = match el.child("contact_weight") {
            Some(c) => c.numbers()?,
            None => setup
                .static_optimization()
                .ok_or_else(|| el.error(format!("{file} has no StaticOptimization")))?
                .contact_weights
                .clone(),
        };
        if w0s.is_empty() {
            return Err(el.error("contact_weight: give one or more w0"));
        }
        let mut specs = Vec::new();
        let mut names = Vec::new();
        // Unknown children are reported (or read on past, with
        // --allow-unknown) by `parse::known::study_elements`.
        for (k, c) in el.children.iter().enumerate() {
            if c.name != "Candidate" {
                continue;
            }
            let mut spec = CandidateSpec::default();
            for p in &c.children {
                match p.name.as_str() {
                    "expression" => spec.expressions.push((
                        p.attr("force")
                            .ok_or_else(|| p.error("an expression needs a force attribute"))?
                            .to_string(),
                        p.text.trim().to_string(),
                    )),
                    "optimal_force" => spec.optimal_forces.push((
                        p.attr("actuator")
                            .ok_or_else(|| p.error("an optimal_force needs an actuator attribute"))?
                            .to_string(),
                        p.numbers_n(1)?[0],
                    )),
                    "external_scale" => spec.external_scales.push((
                        p.attr("force").unwrap_or("*").to_string(),
                        p.numbers_n(1)?[0],
                    )),
                    _ => {}
                }
            }
            let name = c
                .attr("name")
                .map(str::to_string)
                .unwrap_or_else(|| format!("candidate_{k}"));
            for &w0 in &w0s {
                specs.push(CandidateSpec { w0, ..spec.clone() });
                names.push(name.clone());
            }
        }
        if specs.is_empty() {
            return Err(el.error("a ForceSweep needs at least one <Candidate>"));
        }
        let write_tables = match el.child("write_tables") {
            Some(c) => match c.text.trim() {
                "true" => true,
                "false" => false,
                other => {
                    return Err(c.error(format!("write_tables: '{other}' is not true or false")))
                }
            },
            None => false,
        };
        Ok(ForceSweepPlan {
            name: el.attr("name").unwrap_or("force_sweep").to_string(),
            setup_file: path,
            setup,
            specs,
            names,
            write_tables,
            loc: el.loc(),
        })
    }
}
