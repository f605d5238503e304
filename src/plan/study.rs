//! A study document (`<StatoptStudy>`, see `tools::study`) as a typed
//! value: its setups read once, its force sweeps, its figures and metrics
//! (statopt's own elements, checked here and kept with their file and
//! line), where its own outputs go.

use std::path::{Path, PathBuf};

use crate::error::{Error, Location, Result};
use crate::parse::figures::{FigureOrMetric, FigureSpec, MetricSpec};
use crate::parse::setup::{resolve, Setup};
use crate::plan::force_sweep::ForceSweepPlan;
use crate::xml::Element;

/// Whether a parsed document is a study document.
pub fn is_study_document(root: &Element) -> bool {
    root.name == "StatoptStudy" || root.child("StatoptStudy").is_some()
}

/// What a study document says, before any setup it names is read (what
/// `--check` needs to report every problem of a study at once).
#[derive(Debug)]
pub struct StudyDocument {
    pub file: PathBuf,
    /// The folder its relative paths start from.
    pub dir: PathBuf,
    /// The `name` attribute (`study` when absent): its metrics go to
    /// `<name>_metrics.csv`.
    pub name: String,
    /// Where its figures and metrics go, and where that is said.
    pub results_directory: PathBuf,
    pub results_directory_loc: Location,
    /// `<setups>`, resolved against [`StudyDocument::dir`].
    pub setup_files: Vec<PathBuf>,
    /// `<ForceSweep>` elements (read by [`StudyPlan::from_document`]).
    pub sweeps: Vec<Element>,
    /// The setups the force sweeps name (their `setup` attributes),
    /// resolved against [`StudyDocument::dir`].
    pub sweep_setup_files: Vec<PathBuf>,
    /// `<Figure>` and `<Metric>` elements, in the document's order (typed
    /// by [`StudyPlan::from_document`]).
    pub figures: Vec<Element>,
    /// Elements neither statopt nor OpenSim knows, one error each.
    pub unknown: Vec<Error>,
    /// The `<StatoptStudy>` element, for located messages.
    pub element: Element,
}

impl StudyDocument {
    /// Read a parsed study document (the file `path`).
    pub fn from_root(root: &Element, path: &Path) -> Result<Self> {
        let study = if root.name == "StatoptStudy" {
            root
        } else {
            root.child("StatoptStudy")
                .ok_or_else(|| root.error("no <StatoptStudy>"))?
        };
        let dir = match path.parent() {
            Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
            _ => PathBuf::from("."),
        };
        Ok(StudyDocument {
            file: path.to_path_buf(),
            name: study.attr("name").unwrap_or("study").to_string(),
            results_directory: resolve(&dir, study.child_text("results_directory").unwrap_or(".")),
            results_directory_loc: study.child("results_directory").unwrap_or(study).loc(),
            setup_files: study
                .child("setups")
                .map(|s| s.words())
                .unwrap_or_default()
                .iter()
                .map(|s| resolve(&dir, s))
                .collect(),
            sweeps: study
                .children
                .iter()
                .filter(|c| c.name == "ForceSweep")
                .cloned()
                .collect(),
            sweep_setup_files: study
                .children
                .iter()
                .filter(|c| c.name == "ForceSweep")
                .filter_map(|c| c.attr("setup"))
                .map(|f| resolve(&dir, f))
                .collect(),
            figures: study
                .children
                .iter()
                .filter(|c| c.name == "Figure" || c.name == "Metric")
                .cloned()
                .collect(),
            unknown: crate::parse::known::study_elements(study),
            element: study.clone(),
            dir,
        })
    }

    /// Read a study document file.
    pub fn read(path: &Path) -> Result<Self> {
        Self::from_root(&crate::parse::setup::read_document(path)?, path)
    }
}

/// One setup of a study, read.
#[derive(Debug, Clone)]
pub struct StudyRun {
    pub file: PathBuf,
    pub setup: Setup,
}

/// A study, every setup and force sweep it names read into its typed plan.
#[derive(Debug, Clone)]
pub struct StudyPlan {
    pub file: PathBuf,
    pub dir: PathBuf,
    pub name: String,
    pub results_directory: PathBuf,
    pub results_directory_loc: Location,
    pub runs: Vec<StudyRun>,
    pub sweeps: Vec<ForceSweepPlan>,
    /// `<Figure>` and `<Metric>` elements as typed values (every attribute
    /// read and checked, `plan::figures`), in the document's order.
    pub figures: Vec<FigureOrMetric>,
    /// Unknown elements read on past (`allow_unknown`).
    pub warnings: Vec<String>,
}

impl StudyPlan {
    /// Read a study document file and every setup it names.
    pub fn read(path: &Path, allow_unknown: bool) -> Result<Self> {
        Self::from_document(StudyDocument::read(path)?, allow_unknown)
    }

    /// The plan of a study document: an unknown element is an error
    /// (`allow_unknown`: a warning); every setup and force sweep is read.
    pub fn from_document(doc: StudyDocument, allow_unknown: bool) -> Result<Self> {
        let mut warnings = Vec::new();
        if let Some(first) = doc.unknown.into_iter().next() {
            if !allow_unknown {
                return Err(first);
            }
            warnings.push(crate::parse::setup::read_on_warning(&first));
        }
        if doc.setup_files.is_empty() && doc.sweeps.is_empty() {
            return Err(doc
                .element
                .error("the study names no <setups> (and has no <ForceSweep>)"));
        }
        let sweeps = doc
            .sweeps
            .iter()
            .map(|sw| ForceSweepPlan::from_element(sw, &doc.dir, allow_unknown))
            .collect::<Result<Vec<_>>>()?;
        let runs = doc
            .setup_files
            .iter()
            .map(|f| {
                Ok(StudyRun {
                    file: f.clone(),
                    setup: Setup::read_with(f, allow_unknown)?,
                })
            })
            .collect::<Result<Vec<_>>>()?;
        let figures = doc
            .figures
            .iter()
            .map(|el| match el.name.as_str() {
                "Figure" => FigureSpec::from_xml(el).map(FigureOrMetric::Figure),
                _ => MetricSpec::from_xml(el).map(FigureOrMetric::Metric),
            })
            .collect::<Result<Vec<_>>>()?;
        Ok(StudyPlan {
            file: doc.file,
            dir: doc.dir,
            name: doc.name,
            results_directory: doc.results_directory,
            results_directory_loc: doc.results_directory_loc,
            runs,
            sweeps,
            figures,
            warnings,
        })
    }
}
