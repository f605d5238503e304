//! Tool setup files (OpenSim style): which tool a setup describes and its
//! properties, with every path resolved relative to the setup's folder, as
//! OpenSim does (opensim-semantics.md §9.1).

use std::path::{Path, PathBuf};

use crate::error::{Error, Result};
use crate::parse::analyses::{JointReactionSetup, StaticOptimizationSetup};
use crate::xml::{self, Element};

/// A parsed setup file.
#[derive(Debug, Clone)]
pub enum Setup {
    InverseDynamics(InverseDynamicsSetup),
    Analyze(AnalyzeSetup),
}

/// OpenSim's AnalyzeTool setup (opensim-semantics.md §9.1).
#[derive(Debug, Clone)]
pub struct AnalyzeSetup {
    /// The tool's `name` attribute: prefix of every output file.
    pub name: String,
    pub setup_file: PathBuf,
    pub model_file: PathBuf,
    /// Artifact (machine, device) models merged into the model before it is
    /// compiled (`<artifact_files>`, statopt's extension; docs/composition.md).
    pub artifact_files: Vec<PathBuf>,
    pub replace_force_set: bool,
    pub force_set_files: Vec<PathBuf>,
    /// Force-set documents a tool adds in memory, read after
    /// `force_set_files` (predict-grf's root residuals and foot contacts:
    /// its plan is the user's plus these; each element keeps the file and
    /// line it came from).
    pub force_set_documents: Vec<Element>,
    pub results_directory: PathBuf,
    /// Where `<results_directory>` stands (the tool element when absent).
    pub results_directory_loc: crate::error::Location,
    pub output_precision: usize,
    pub initial_time: f64,
    pub final_time: f64,
    pub external_loads_file: Option<PathBuf>,
    pub states_file: Option<PathBuf>,
    pub coordinates_file: Option<PathBuf>,
    pub speeds_file: Option<PathBuf>,
    pub lowpass_cutoff: f64,
    /// statopt: `CONTACT=COORDINATE` pairs; the coordinate is solved on every
    /// row of the motion so that the contact stays closed (e.g. a machine's
    /// lever angle from its pad on the shin), before speeds are splined.
    pub close_contacts: Vec<(String, String)>,
    /// Where `<close_contacts>` stands, for errors about its entries.
    pub close_contacts_loc: Option<crate::error::Location>,
    /// statopt: `<reduce_model>`: static optimization runs on the model
    /// reduced to what the motion needs (`tools::reduce`; CLI `--reduce`).
    pub reduce_model: bool,
    /// statopt: degree of the interpolating spline through the coordinates
    /// and speeds (`<coordinate_spline>gcv5|cubic</coordinate_spline>`): 5,
    /// OpenSim's quintic GCV spline (default), or 3, a natural cubic.
    pub coordinate_spline: usize,
    /// statopt: `<Figure>` and `<Metric>` elements (`parse::figures`; see
    /// `tools::study`), drawn from the run's tables after the analyses.
    pub figures: Vec<crate::parse::figures::FigureOrMetric>,
    pub analyses: Vec<Analysis>,
    /// Factors on the force and torque data of the external loads, by
    /// ExternalForce name (`*`: every one), set by
    /// [`AnalyzeSetup::set_external_load_scales`] (the Python package's
    /// `external_load_scale`); empty: the data as read.
    pub external_load_scales: Vec<(String, f64)>,
    /// Non-fatal remarks (unknown elements read on with `--allow-unknown`,
    /// see `parse::known`).
    pub warnings: Vec<String>,
    /// OpenSim properties the setup holds that statopt accepts but does not
    /// use (`parse::known::UNUSED_SETUP_PROPERTIES`), e.g.
    /// `AnalyzeTool <maximum_integrator_step_size>`: listed in the summary.
    pub unused_properties: Vec<String>,
}

/// Properties every OpenSim analysis has.
#[derive(Debug, Clone)]
pub struct AnalysisCommon {
    pub name: String,
    pub on: bool,
    pub step_interval: usize,
    pub in_degrees: bool,
}

/// An analysis of the setup's AnalysisSet, read once into its typed
/// settings (`parse::analyses`); tools never read its XML again.
#[derive(Debug, Clone)]
pub enum Analysis {
    MuscleAnalysis(MuscleAnalysisSetup),
    StaticOptimization(Box<StaticOptimizationSetup>),
    JointReaction(Box<JointReactionSetup>),
    /// BodyKinematics or PointKinematics (`parse::kinematics`).
    Kinematics(Box<crate::parse::kinematics::KinematicsSetup>),
    /// An analysis OpenSim knows that statopt does not run (refused when
    /// it is on).
    Unsupported {
        common: AnalysisCommon,
        element: Element,
    },
}

impl Analysis {
    /// The properties every analysis has.
    pub fn common(&self) -> &AnalysisCommon {
        match self {
            Analysis::MuscleAnalysis(m) => &m.common,
            Analysis::StaticOptimization(s) => &s.common,
            Analysis::JointReaction(j) => &j.common,
            Analysis::Kinematics(k) => k.common(),
            Analysis::Unsupported { common, .. } => common,
        }
    }
}

/// Typed edits of an AnalyzeTool plan (`bench`, `bench --grid`,
/// predict-grf, `--reduce`), checked as the values read from a setup are
/// where reading checks them; an error names the setup file.
impl AnalyzeSetup {
    fn edit_error(&self, message: String) -> Error {
        Error::input(crate::error::Location::file(&self.setup_file), message)
    }

    /// `<lowpass_cutoff_frequency_for_coordinates>` (Hz; negative: no
    /// filter, as OpenSim's -1): a finite number.
    pub fn set_lowpass_cutoff(&mut self, hz: f64) -> Result<()> {
        if !hz.is_finite() {
            return Err(self.edit_error(format!(
                "lowpass_cutoff_frequency_for_coordinates must be a finite number (negative: no filter), found {hz}"
            )));
        }
        self.lowpass_cutoff = hz;
        Ok(())
    }

    /// `<coordinate_spline>`: 5 (OpenSim's quintic GCV spline) or 3 (cubic).
    pub fn set_coordinate_spline(&mut self, order: usize) -> Result<()> {
        if order != 3 && order != 5 {
            return Err(self.edit_error(format!(
                "coordinate_spline must be 5 (gcv5, OpenSim's quintic spline) or 3 (cubic), found {order}"
            )));
        }
        self.coordinate_spline = order;
        Ok(())
    }

    /// `<reduce_model>`: run static optimization on the model reduced to
    /// what the motion needs.
    pub fn set_reduce_model(&mut self, reduce: bool) {
        self.reduce_model = reduce;
    }

    /// The external loads file, taken out of the plan: the run applies no
    /// external loads (predict-grf keeps them as its measured reference).
    pub fn take_external_loads_file(&mut self) -> Option<PathBuf> {
        self.external_loads_file.take()
    }

    /// The run's force sets: these parsed documents (each with the file it
    /// stands for), instead of the setup's force-set files.
    pub fn set_force_set_documents(&mut self, documents: Vec<Element>) {
        self.force_set_files.clear();
        self.force_set_documents = documents;
    }

    /// The motion: `coordinates_file` over [`initial`, `final_time`] (s), a
    /// finite, ordered range.
    pub fn set_motion(
        &mut self,
        coordinates_file: PathBuf,
        initial: f64,
        final_time: f64,
    ) -> Result<()> {
        if !(initial.is_finite() && final_time.is_finite() && initial <= final_time) {
            return Err(self.edit_error(format!(
                "the time range must be finite and ordered, found [{initial}, {final_time}]"
            )));
        }
        self.coordinates_file = Some(coordinates_file);
        self.initial_time = initial;
        self.final_time = final_time;
        Ok(())
    }
}

impl AnalyzeSetup {
    /// Scale the force and torque data of the external loads `scales`
    /// names (ExternalForce name or `*`, factor), as a force sweep's
    /// `<external_scale>` does ([`Setup::set_external_load_scales`]).
    pub fn set_external_load_scales(&mut self, scales: &[(String, f64)]) -> Result<()> {
        self.external_load_scales =
            checked_load_scales(&self.setup_file, self.external_loads_file.is_some(), scales)?;
        Ok(())
    }

    /// The setup file's folder, which relative paths in it start from.
    pub fn dir(&self) -> &Path {
        self.setup_file.parent().unwrap_or(Path::new("."))
    }

    /// The element and common settings of the first analysis of type
    /// `type_name` (e.g. `StaticOptimization`), on or off (for located
    /// messages; the settings are [`AnalyzeSetup::static_optimization`] and
    /// [`AnalyzeSetup::joint_reactions`]).
    pub fn analysis_element(&self, type_name: &str) -> Option<(&Element, &AnalysisCommon)> {
        self.analyses.iter().find_map(|a| match a {
            Analysis::StaticOptimization(s) if type_name == "StaticOptimization" => {
                Some((&s.element, &s.common))
            }
            Analysis::JointReaction(j) if type_name == "JointReaction" => {
                Some((&j.element, &j.common))
            }
            Analysis::Unsupported { element, common } if element.name == type_name => {
                Some((element, common))
            }
            _ => None,
        })
    }

    /// The first StaticOptimization analysis, on or off.
    pub fn static_optimization(&self) -> Option<&StaticOptimizationSetup> {
        self.analyses.iter().find_map(|a| match a {
            Analysis::StaticOptimization(s) => Some(&**s),
            _ => None,
        })
    }

    /// The JointReaction analyses, on or off.
    pub fn joint_reactions(&self) -> impl Iterator<Item = &JointReactionSetup> {
        self.analyses.iter().filter_map(|a| match a {
            Analysis::JointReaction(j) => Some(&**j),
            _ => None,
        })
    }
}

#[derive(Debug, Clone)]
pub struct MuscleAnalysisSetup {
    pub common: AnalysisCommon,
    /// Muscle names, or `all`.
    pub muscle_list: Vec<String>,
    /// Coordinates for moment-arm files, or `all`.
    pub moment_arm_coordinate_list: Vec<String>,
    pub compute_moments: bool,
}

#[derive(Debug, Clone)]
pub struct InverseDynamicsSetup {
    /// The tool's `name` attribute.
    pub name: String,
    pub setup_file: PathBuf,
    pub model_file: PathBuf,
    /// Artifact models merged into the model (`<artifact_files>`, statopt's extension).
    pub artifact_files: Vec<PathBuf>,
    pub coordinates_file: PathBuf,
    /// Negative: no filtering.
    pub lowpass_cutoff: f64,
    pub time_range: (f64, f64),
    pub forces_to_exclude: Vec<String>,
    pub external_loads_file: Option<PathBuf>,
    pub results_directory: PathBuf,
    /// Where `<results_directory>` stands (the tool element when absent).
    pub results_directory_loc: crate::error::Location,
    pub output_gen_force_file: String,
    pub joints_to_report_body_forces: Vec<String>,
    pub output_body_forces_file: Option<String>,
    /// Non-fatal remarks (unknown elements read on with `--allow-unknown`).
    pub warnings: Vec<String>,
    /// OpenSim properties statopt accepts but does not use (see
    /// [`AnalyzeSetup::unused_properties`]).
    pub unused_properties: Vec<String>,
    /// Factors on the external loads' force and torque data, by
    /// ExternalForce name (`*`: all): [`Setup::set_external_load_scales`].
    pub external_load_scales: Vec<(String, f64)>,
}

impl InverseDynamicsSetup {
    /// The setup file's folder, which relative paths in it start from.
    pub fn dir(&self) -> &Path {
        self.setup_file.parent().unwrap_or(Path::new("."))
    }
}

/// What stops `dir` from being a results folder (it or a folder above it
/// is a file, or the nearest existing folder above it is read-only), said
/// as the end of a sentence naming `dir`; None when a run can write there.
/// Nothing is created (for `--check`).
pub fn results_dir_problem(dir: &Path) -> Option<String> {
    if dir.exists() {
        return (!dir.is_dir()).then(|| "is a file, not a folder".to_string());
    }
    let mut up = dir.parent();
    while let Some(p) = up {
        let p = if p.as_os_str().is_empty() {
            Path::new(".")
        } else {
            p
        };
        if p.exists() {
            if !p.is_dir() {
                return Some(format!(
                    "cannot be created: {} is a file, not a folder",
                    p.display()
                ));
            }
            if std::fs::metadata(p).is_ok_and(|m| m.permissions().readonly()) {
                return Some(format!("cannot be created: {} is read-only", p.display()));
            }
            return None;
        }
        up = p.parent();
    }
    None
}

/// Create the results folder `dir` (the error names the setup's
/// `<results_directory>`, at `loc`, or the command line's `-o`).
pub fn create_results_dir(dir: &Path, loc: &crate::error::Location, from_cli: bool) -> Result<()> {
    if let Some(p) = results_dir_problem(dir) {
        return Err(results_dir_error(dir, loc, from_cli, &p));
    }
    // A run kept in memory creates no folder (storage::results).
    if !crate::storage::results::writes_file(dir) {
        return Ok(());
    }
    std::fs::create_dir_all(dir)
        .map_err(|e| results_dir_error(dir, loc, from_cli, &format!("cannot be created: {e}")))
}

/// The error for a results folder `dir` a run cannot write to (`problem`,
/// e.g. from [`results_dir_problem`]): it names the setup's
/// `<results_directory>` (at `loc`) or the command line's `-o`.
pub fn results_dir_error(
    dir: &Path,
    loc: &crate::error::Location,
    from_cli: bool,
    problem: &str,
) -> Error {
    if from_cli {
        Error::msg(format!(
            "-o {}: the results folder {problem}",
            dir.display()
        ))
    } else {
        Error::input(
            loc.clone(),
            format!(
                "<results_directory> names {}, which {problem}",
                dir.display()
            ),
        )
    }
}

/// Resolve a path from a setup relative to the setup's folder.
pub fn resolve(setup_dir: &Path, p: &str) -> PathBuf {
    let p = Path::new(p.trim());
    if p.is_absolute() {
        p.to_path_buf()
    } else {
        tidy(&setup_dir.join(p))
    }
}

/// `setups/../output` as `output`, the way a user reads it in a message:
/// a `..` is folded into the component before it only where that is a
/// folder (not a symbolic link, after which `..` leads elsewhere), so the
/// path names the same file; a leading `./` is dropped.
pub fn tidy(p: &Path) -> PathBuf {
    use std::path::Component;
    let mut out = PathBuf::new();
    for c in p.components() {
        match c {
            Component::CurDir => {}
            Component::ParentDir
                if matches!(out.components().next_back(), Some(Component::Normal(_)))
                    && out.symlink_metadata().is_ok_and(|m| m.is_dir()) =>
            {
                out.pop();
            }
            c => out.push(c),
        }
    }
    if out.as_os_str().is_empty() {
        PathBuf::from(".")
    } else {
        out
    }
}

/// A whitespace-separated list of file names, resolved against the setup's folder.
fn path_list(tool: &Element, name: &str, dir: &Path) -> Vec<PathBuf> {
    tool.child(name)
        .map(|e| e.words())
        .unwrap_or_default()
        .iter()
        .filter(|w| w.as_str() != "Unassigned")
        .map(|p| resolve(dir, p))
        .collect()
}

/// Every input file a setup names must exist; the error names the setup,
/// the element and its line (a missing model used to be reported by its
/// path alone, without saying which element named it).
fn check_inputs_exist(tool: &Element, dir: &Path, model_only: bool) -> Result<()> {
    match missing_inputs(tool, dir, model_only).into_iter().next() {
        Some(e) => Err(e),
        None => Ok(()),
    }
}

/// Every input file a setup document names that is not there, one error
/// each (for `--check`, which reports all problems at once).
pub fn missing_input_files(setup: &Path) -> Result<Vec<Error>> {
    let root = read_document(setup)?;
    let tool = tool_element(&root)?;
    Ok(missing_inputs(tool, &setup_dir(setup), false))
}

/// The tool element of a setup document (the root, or the first child of
/// an `OpenSimDocument`).
fn tool_element(root: &Element) -> Result<&Element> {
    if root.name == "OpenSimDocument" {
        root.children
            .first()
            .ok_or_else(|| root.error("the setup holds no tool element"))
    } else {
        Ok(root)
    }
}

/// The folder paths in a setup are relative to ("." for a bare file name).
fn setup_dir(path: &Path) -> PathBuf {
    match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    }
}

/// The files a setup names; with `model_only`, those the model is made of
/// (model, artifacts, force sets) and not the data it runs on (motion,
/// states, speeds, external loads).
fn missing_inputs(tool: &Element, dir: &Path, model_only: bool) -> Vec<Error> {
    let mut out = Vec::new();
    let missing = |el: &Element, p: &str| -> Result<()> {
        let path = resolve(dir, p);
        if path.exists() {
            Ok(())
        } else {
            Err(el.error(format!(
                "file not found: {} (a relative path is taken from the setup's folder, as in OpenSim)",
                path.display()
            )))
        }
    };
    let data = [
        "coordinates_file",
        "states_file",
        "speeds_file",
        "external_loads_file",
    ];
    let names = std::iter::once("model_file").chain(data.into_iter().filter(|_| !model_only));
    for name in names {
        if let (Some(el), Some(text)) = (tool.child(name), opt_text(tool, name)) {
            if let Err(e) = missing(el, &text) {
                out.push(e);
            }
        }
    }
    for name in ["artifact_files", "force_set_files"] {
        if let Some(el) = tool.child(name) {
            for w in el.words().iter().filter(|w| w.as_str() != "Unassigned") {
                if let Err(e) = missing(el, w) {
                    out.push(e);
                }
            }
        }
    }
    out
}

fn opt_text(el: &Element, name: &str) -> Option<String> {
    el.child_text(name)
        .filter(|s| !s.is_empty() && *s != "Unassigned")
        .map(str::to_string)
}

/// Parse a setup or study document, the file the user named: a file that
/// is not there, or cannot be read, is said to be the setup (a bare "cannot
/// read or write file" did not say which file of a run it was).
pub fn read_document(path: &Path) -> Result<Element> {
    match std::fs::metadata(path) {
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            return Err(Error::input(
                crate::error::Location::file(path),
                "no such setup file",
            ))
        }
        Ok(m) if m.is_dir() => {
            return Err(Error::input(
                crate::error::Location::file(path),
                "is a folder, not a setup file",
            ))
        }
        _ => {}
    }
    xml::parse_file(path).map_err(|e| match e {
        Error::Input { loc, msg } if msg.starts_with("cannot read or write file") => Error::Input {
            loc,
            msg: format!(
                "cannot read the setup file: {}",
                msg.trim_start_matches("cannot read or write file: ")
            ),
        },
        e => e,
    })
}

/// The warning for an unknown element read on past (`--allow-unknown`):
/// the error's message without its advice to use that option.
pub fn read_on_warning(e: &Error) -> String {
    let text = e.to_string();
    let cut = text.find(" (statopt refuses").unwrap_or(text.len());
    format!("{} (read on: --allow-unknown)", &text[..cut])
}

/// Every element of a setup document neither OpenSim 4.6 nor statopt
/// knows, one error each (for `--check`, which reports all problems at
/// once; see `parse::known::setup_elements`).
pub fn unknown_elements(setup: &Path) -> Result<Vec<Error>> {
    let root = read_document(setup)?;
    Ok(super::known::setup_elements(tool_element(&root)?).unknown)
}

/// External load scales checked: finite factors, and external loads to
/// scale; the names are checked against the loads when they are read
/// (`forces::external_loads::ExternalLoads::scale`).
fn checked_load_scales(
    setup_file: &Path,
    has_loads: bool,
    scales: &[(String, f64)],
) -> Result<Vec<(String, f64)>> {
    let loc = crate::error::Location::file(setup_file);
    if scales.is_empty() {
        return Ok(Vec::new());
    }
    if !has_loads {
        return Err(Error::input(
            loc.with_element("external_loads_file"),
            "external load scales: the setup has no external loads",
        ));
    }
    if let Some((name, f)) = scales.iter().find(|(_, f)| !f.is_finite()) {
        return Err(Error::input(
            loc,
            format!("external load scale {f} of '{name}' is not a finite number"),
        ));
    }
    Ok(scales.to_vec())
}

impl Setup {
    /// Scale the force and torque data of the external loads `scales`
    /// names (ExternalForce name or `*`, factor) as they are read: the
    /// Python package's `external_load_scale` (no scaled copy of the data
    /// file is written).
    pub fn set_external_load_scales(&mut self, scales: &[(String, f64)]) -> Result<()> {
        match self {
            Setup::Analyze(a) => a.set_external_load_scales(scales),
            Setup::InverseDynamics(i) => {
                i.external_load_scales =
                    checked_load_scales(&i.setup_file, i.external_loads_file.is_some(), scales)?;
                Ok(())
            }
        }
    }
    /// Read a setup file. An element neither OpenSim 4.6 nor statopt knows
    /// is an error (see [`Setup::read_with`]).
    pub fn read(path: &Path) -> Result<Setup> {
        Self::read_with(path, false)
    }

    /// Read a setup file; with `allow_unknown` (`--allow-unknown`) an
    /// unknown element is a warning instead of an error.
    pub fn read_with(path: &Path, allow_unknown: bool) -> Result<Setup> {
        Self::from_document(&read_document(path)?, path, allow_unknown)
    }

    /// Read a setup for its model (`statopt-tool motion --setup`, which
    /// writes the setup's motion): the model, artifact and force-set files
    /// must exist, the motion, states, speeds and external loads need not.
    pub fn read_for_model(path: &Path) -> Result<Setup> {
        Self::from_document_checking(&xml::parse_file(path)?, path, false, true)
    }

    /// A setup document given as text, read as if it were the file `path`:
    /// relative paths resolve against `path`'s folder and messages name
    /// `path` (callers that edit a setup in memory, e.g. the Python package).
    pub fn parse(text: &str, path: &Path) -> Result<Setup> {
        Self::parse_with(text, path, false)
    }

    /// [`Setup::parse`], unknown elements allowed or not (see [`Setup::read_with`]).
    pub fn parse_with(text: &str, path: &Path, allow_unknown: bool) -> Result<Setup> {
        Self::from_document(&xml::parse_str(text, path)?, path, allow_unknown)
    }

    /// Non-fatal remarks of reading it: unknown elements read on with
    /// `allow_unknown`.
    pub fn warnings(&self) -> &[String] {
        match self {
            Setup::Analyze(a) => &a.warnings,
            Setup::InverseDynamics(i) => &i.warnings,
        }
    }

    /// The setup of a parsed document (the file `path`; see [`Setup::read_with`]).
    pub fn from_document(root: &Element, path: &Path, allow_unknown: bool) -> Result<Setup> {
        Self::from_document_checking(root, path, allow_unknown, false)
    }

    fn from_document_checking(
        root: &Element,
        path: &Path,
        allow_unknown: bool,
        model_only: bool,
    ) -> Result<Setup> {
        let tool = tool_element(root)?;
        let dir = setup_dir(path);
        let found = super::known::setup_elements(tool);
        if !allow_unknown {
            if let Some(first) = found.unknown.first() {
                let more = found.unknown.len() - 1;
                let e = Error::input(
                    match first {
                        Error::Input { loc, .. } => (**loc).clone(),
                        Error::Internal(_) => crate::error::Location::file(path),
                    },
                    match first {
                        Error::Input { msg, .. } if more > 0 => format!(
                            "{msg}; {more} more unknown element(s) follow (statopt-tool --check lists them all)"
                        ),
                        Error::Input { msg, .. } => msg.clone(),
                        Error::Internal(m) => m.clone(),
                    },
                );
                return Err(e);
            }
        }
        let warnings: Vec<String> = found.unknown.iter().map(read_on_warning).collect();
        let mut unused = found.unused;
        unused.dedup();
        if matches!(tool.name.as_str(), "InverseDynamicsTool" | "AnalyzeTool") {
            check_inputs_exist(tool, &dir, model_only)?;
        }
        match tool.name.as_str() {
            "InverseDynamicsTool" => {
                let mut s = read_id(tool, path, &dir)?;
                s.warnings = warnings;
                s.unused_properties = unused;
                Ok(Setup::InverseDynamics(s))
            }
            "AnalyzeTool" => {
                let mut s = read_analyze(tool, path, &dir)?;
                s.warnings = warnings;
                s.unused_properties = unused;
                Ok(Setup::Analyze(s))
            }
            other => Err(tool.error(format!(
                "'{other}' setups are not supported; supported: InverseDynamicsTool, AnalyzeTool"
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
            let v = t.numbers_allow_inf()?;
            if v.len() != 2 {
                return Err(t.error(format!("expected 2 numbers, found {}", v.len())));
            }
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
        artifact_files: path_list(tool, "artifact_files", dir),
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
        results_directory_loc: tool.child("results_directory").unwrap_or(tool).loc(),
        output_gen_force_file: opt_text(tool, "output_gen_force_file")
            .unwrap_or_else(|| "inverse_dynamics.sto".into()),
        joints_to_report_body_forces: joints,
        output_body_forces_file: opt_text(tool, "output_body_forces_file"),
        external_load_scales: Vec::new(),
        warnings: Vec::new(),
        unused_properties: Vec::new(),
    })
}

fn words_or_all(el: &Element, name: &str) -> Vec<String> {
    match el.child(name) {
        Some(c) if !c.text().is_empty() => c.words(),
        _ => vec!["all".into()],
    }
}

/// The properties every analysis has, of the analysis element `a`.
pub fn read_common(a: &Element) -> Result<AnalysisCommon> {
    let step = match a.child("step_interval") {
        Some(s) if !s.text().is_empty() => {
            let v = s.int()?;
            if v < 1 {
                return Err(s.error(format!(
                    "step_interval must be a positive integer, found {v}"
                )));
            }
            v as usize
        }
        _ => 1,
    };
    Ok(AnalysisCommon {
        name: a.attr("name").unwrap_or(&a.name).to_string(),
        on: a.child_bool_or("on", true)?,
        step_interval: step,
        in_degrees: a.child_bool_or("in_degrees", true)?,
    })
}

fn read_analyze(tool: &Element, path: &Path, dir: &Path) -> Result<AnalyzeSetup> {
    let model_file =
        opt_text(tool, "model_file").ok_or_else(|| tool.error("missing <model_file>"))?;
    let precision = match tool.child("output_precision") {
        Some(p) if !p.text().is_empty() => {
            let v = p.int()?;
            if !(1..=20).contains(&v) {
                return Err(p.error(format!(
                    "output_precision must be between 1 and 20, found {v}"
                )));
            }
            v as usize
        }
        _ => 8,
    };
    let mut analyses = Vec::new();
    if let Some(set) = tool.child("AnalysisSet").and_then(|s| s.child("objects")) {
        for a in &set.children {
            let common = read_common(a)?;
            analyses.push(match a.name.as_str() {
                "MuscleAnalysis" => Analysis::MuscleAnalysis(MuscleAnalysisSetup {
                    muscle_list: words_or_all(a, "muscle_list"),
                    moment_arm_coordinate_list: words_or_all(a, "moment_arm_coordinate_list"),
                    compute_moments: a.child_bool_or("compute_moments", true)?,
                    common,
                }),
                "StaticOptimization" => Analysis::StaticOptimization(Box::new(
                    StaticOptimizationSetup::from_xml(a, common)?,
                )),
                "JointReaction" => {
                    Analysis::JointReaction(Box::new(JointReactionSetup::from_xml(a, common, dir)?))
                }
                "BodyKinematics" | "PointKinematics" => Analysis::Kinematics(Box::new(
                    crate::parse::kinematics::KinematicsSetup::from_xml(a, common)?
                        .expect("a kinematics element"),
                )),
                _ => Analysis::Unsupported {
                    common,
                    element: a.clone(),
                },
            });
        }
    }
    let initial_time = tool.child_f64_or_inf("initial_time", 0.0)?;
    let final_time = tool.child_f64_or_inf("final_time", 1.0)?;
    if initial_time > final_time {
        return Err(tool.req("initial_time")?.error(format!(
            "initial_time {initial_time} is after final_time {final_time}"
        )));
    }
    let coordinates_file = opt_text(tool, "coordinates_file").map(|p| resolve(dir, &p));
    let states_file = opt_text(tool, "states_file").map(|p| resolve(dir, &p));
    if coordinates_file.is_none() && states_file.is_none() {
        return Err(tool.error("the setup names neither a <coordinates_file> nor a <states_file>"));
    }
    Ok(AnalyzeSetup {
        name: tool.attr("name").unwrap_or("").to_string(),
        setup_file: path.to_path_buf(),
        model_file: resolve(dir, &model_file),
        artifact_files: path_list(tool, "artifact_files", dir),
        replace_force_set: tool.child_bool_or("replace_force_set", false)?,
        force_set_files: tool
            .child("force_set_files")
            .map(|e| e.words())
            .unwrap_or_default()
            .iter()
            .map(|p| resolve(dir, p))
            .collect(),
        force_set_documents: Vec::new(),
        results_directory: resolve(
            dir,
            &opt_text(tool, "results_directory").unwrap_or_else(|| ".".into()),
        ),
        results_directory_loc: tool.child("results_directory").unwrap_or(tool).loc(),
        output_precision: precision,
        initial_time,
        final_time,
        external_loads_file: opt_text(tool, "external_loads_file").map(|p| resolve(dir, &p)),
        states_file,
        coordinates_file,
        speeds_file: opt_text(tool, "speeds_file").map(|p| resolve(dir, &p)),
        lowpass_cutoff: tool.child_f64_or("lowpass_cutoff_frequency_for_coordinates", -1.0)?,
        close_contacts: match tool.child("close_contacts") {
            Some(c) => c
                .words()
                .iter()
                .map(|w| match w.split_once('=') {
                    Some((a, b)) if !a.is_empty() && !b.is_empty() => {
                        Ok((a.to_string(), b.to_string()))
                    }
                    _ => Err(c.error(format!(
                        "close_contacts entry '{w}' must be CONTACT=COORDINATE"
                    ))),
                })
                .collect::<Result<Vec<_>>>()?,
            None => Vec::new(),
        },
        close_contacts_loc: tool.child("close_contacts").map(Element::loc),
        reduce_model: tool.child_bool_or("reduce_model", false)?,
        coordinate_spline: match tool.child("coordinate_spline") {
            Some(c) if !c.text().is_empty() => match c.text().to_ascii_lowercase().as_str() {
                "gcv5" | "quintic" => 5,
                "cubic" => 3,
                other => {
                    return Err(c.error(format!(
                        "coordinate_spline must be 'gcv5' (OpenSim's quintic spline) or 'cubic', found '{other}'"
                    )))
                }
            },
            _ => 5,
        },
        figures: crate::parse::figures::FigureOrMetric::read_children(tool)?,
        analyses,
        external_load_scales: Vec::new(),
        warnings: Vec::new(),
        unused_properties: Vec::new(),
    })
}
