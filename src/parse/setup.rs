//! Tool setup files (OpenSim style): which tool a setup describes and its
//! properties, with every path resolved relative to the setup's folder, as
//! OpenSim does (opensim-semantics.md §9.1).

use std::path::{Path, PathBuf};

use crate::error::Result;
use crate::xml::{self, Element};

/// A parsed setup file.
#[derive(Debug, Clone)]
pub enum Setup {
    InverseDynamics(InverseDynamicsSetup),
}

#[derive(Debug, Clone)]
pub struct InverseDynamicsSetup {
    /// The tool's `name` attribute.
    pub name: String,
    pub setup_file: PathBuf,
    pub model_file: PathBuf,
    pub coordinates_file: PathBuf,
    /// Negative: no filtering.
    pub lowpass_cutoff: f64,
    pub time_range: (f64, f64),
    pub forces_to_exclude: Vec<String>,
    pub external_loads_file: Option<PathBuf>,
    pub results_directory: PathBuf,
    pub output_gen_force_file: String,
    pub joints_to_report_body_forces: Vec<String>,
    pub output_body_forces_file: Option<String>,
}

/// Resolve a path from a setup relative to the setup's folder.
pub fn resolve(setup_dir: &Path, p: &str) -> PathBuf {
    let p = Path::new(p.trim());
    if p.is_absolute() {
        p.to_path_buf()
    } else {
        setup_dir.join(p)
    }
}

fn opt_text(el: &Element, name: &str) -> Option<String> {
    el.child_text(name)
        .filter(|s| !s.is_empty() && *s != "Unassigned")
        .map(str::to_string)
}

impl Setup {
    pub fn read(path: &Path) -> Result<Setup> {
        let root = xml::parse_file(path)?;
        let tool = if root.name == "OpenSimDocument" {
            root.children
                .first()
                .ok_or_else(|| root.error("the setup holds no tool element"))?
        } else {
            &root
        };
        let dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
        let dir = if dir.as_os_str().is_empty() {
            PathBuf::from(".")
        } else {
            dir
        };
        match tool.name.as_str() {
            "InverseDynamicsTool" => Ok(Setup::InverseDynamics(read_id(tool, path, &dir)?)),
            other => Err(tool.error(format!(
                "'{other}' setups are not supported yet; supported: InverseDynamicsTool"
            ))),
        }
    }
}

fn read_id(tool: &Element, path: &Path, dir: &Path) -> Result<InverseDynamicsSetup> {
    let req_path = |name: &str| -> Result<PathBuf> {
        let t = opt_text(tool, name).ok_or_else(|| tool.error(format!("missing <{name}>")))?;
        Ok(resolve(dir, &t))
    };
    let time_range = match tool.child("time_range") {
        Some(t) if !t.text().is_empty() => {
            let v = t.numbers_n(2)?;
            if v[0] > v[1] {
                return Err(t.error(format!(
                    "time_range start {} is after its end {}",
                    v[0], v[1]
                )));
            }
            (v[0], v[1])
        }
        _ => (f64::NEG_INFINITY, f64::INFINITY),
    };
    let joints = tool
        .child("joints_to_report_body_forces")
        .map(|e| e.words())
        .unwrap_or_default();
    Ok(InverseDynamicsSetup {
        name: tool.attr("name").unwrap_or("").to_string(),
        setup_file: path.to_path_buf(),
        model_file: req_path("model_file")?,
        coordinates_file: req_path("coordinates_file")?,
        lowpass_cutoff: tool.child_f64_or("lowpass_cutoff_frequency_for_coordinates", -1.0)?,
        time_range,
        forces_to_exclude: tool
            .child("forces_to_exclude")
            .map(|e| e.words())
            .unwrap_or_default(),
        external_loads_file: opt_text(tool, "external_loads_file").map(|p| resolve(dir, &p)),
        results_directory: resolve(
            dir,
            &opt_text(tool, "results_directory").unwrap_or_else(|| ".".into()),
        ),
        output_gen_force_file: opt_text(tool, "output_gen_force_file")
            .unwrap_or_else(|| "inverse_dynamics.sto".into()),
        joints_to_report_body_forces: joints,
        output_body_forces_file: opt_text(tool, "output_body_forces_file"),
    })
}
