//! `statopt-tool SETUP --check`: read and compile everything a setup or a
//! study names (files, models, force sets, external loads, the motion, the
//! analyses' problems, a study's figure references) and report every problem
//! found, without solving a frame.
//!
//! The check checks what the run would do, with the same overrides (`-o`,
//! `--reduce`, `--allow-unknown`: [`RunOptions`]). Each stage that does not
//! depend on an earlier one that failed is still checked, so one pass lists
//! everything that would stop a run; but a problem's consequences are not
//! listed after it. Unknown elements (a misspelt property, which the run
//! would refuse) come first, and while a document holds one the figure and
//! metric references are not checked: which tables a setup writes depends
//! on what the element was meant to be (`<contact_wieght>` leaves a single
//! w0, and every reference to a w0 table would look wrong).

use std::path::{Path, PathBuf};

use crate::error::{Error, Location};
use crate::parse::setup::{
    missing_input_files, results_dir_error, results_dir_problem, unknown_elements, Analysis,
    AnalyzeSetup, InverseDynamicsSetup, Setup,
};
pub use crate::tools::figures::figure_reference_problems;
use crate::tools::{inputs, joint_reaction, loading, static_optimization, study, RunOptions};

/// What a check found: errors (each would stop a run) and warnings.
#[derive(Debug, Default)]
pub struct CheckReport {
    /// The root causes first (unknown elements), then the rest in the order
    /// found.
    pub errors: Vec<Error>,
    pub warnings: Vec<String>,
    /// What was not checked, and why (said after the errors).
    pub notes: Vec<String>,
    /// Setups checked (a study's and the study's own document).
    pub checked: Vec<String>,
}

/// Why figure and metric references were not checked (a warning).
const REFERENCES_NOT_CHECKED: &str = "<Figure> and <Metric> references not checked: which \
tables the runs write depends on what the unknown element(s) above were meant to be (fix them and \
check again)";

/// Check a setup or a study document; with `allow_unknown`
/// (`--allow-unknown`) elements neither OpenSim nor statopt knows are
/// warnings, as a run would read on past them.
pub fn run(path: &Path, allow_unknown: bool) -> CheckReport {
    run_with(
        path,
        &RunOptions {
            allow_unknown,
            ..Default::default()
        },
    )
}

/// Check what `statopt-tool SETUP` with `opts` would do: its results folder
/// (`opts.results_dir`, the `-o` of the run, or the setup's), the reduced
/// model with `opts.reduce`, unknown elements as warnings with
/// `opts.allow_unknown`.
pub fn run_with(path: &Path, opts: &RunOptions) -> CheckReport {
    let mut c = Checker {
        allow_unknown: opts.allow_unknown,
        reduce: opts.reduce,
        ..Default::default()
    };
    if crate::plan::is_study(path) {
        c.study(path, opts.results_dir.as_deref());
    } else {
        let out = opts.results_dir.clone().map(|d| (d, true));
        c.setup(path, out);
    }
    let Checker {
        mut unknown,
        errors,
        warnings,
        notes,
        checked,
        ..
    } = c;
    unknown.extend(errors);
    CheckReport {
        errors: unknown,
        warnings,
        notes,
        checked,
    }
}

#[derive(Default)]
struct Checker {
    allow_unknown: bool,
    reduce: bool,
    /// Unknown elements (errors without `allow_unknown`): the root causes.
    unknown: Vec<Error>,
    errors: Vec<Error>,
    warnings: Vec<String>,
    notes: Vec<String>,
    checked: Vec<String>,
    /// The study's `-o` folder cannot be written: its setups' folders
    /// under it are not checked again.
    skip_results_dirs: bool,
}

impl Checker {
    /// Unknown elements of a document; true when they are errors.
    fn unknown(&mut self, unknown: Vec<Error>) -> bool {
        if unknown.is_empty() {
            return false;
        }
        if self.allow_unknown {
            self.warnings
                .extend(unknown.iter().map(crate::parse::setup::read_on_warning));
            false
        } else {
            self.unknown.extend(unknown);
            true
        }
    }

    /// An error, unless the same one was said already (a study's plan reads
    /// its setups again).
    fn error(&mut self, e: Error) {
        let text = e.to_string();
        if !self
            .unknown
            .iter()
            .chain(&self.errors)
            .any(|x| x.to_string() == text)
        {
            self.errors.push(e);
        }
    }

    fn study(&mut self, path: &Path, moved_to: Option<&Path>) {
        let mut doc = match crate::plan::StudyDocument::read(path) {
            Ok(doc) => doc,
            Err(e) => {
                self.error(e);
                self.checked.push(path.display().to_string());
                return;
            }
        };
        let misread = self.unknown(std::mem::take(&mut doc.unknown));
        let (dir, from_cli) = match moved_to {
            Some(d) => (d.to_path_buf(), true),
            None => (doc.results_directory.clone(), false),
        };
        if let Some(p) = results_dir_problem(&dir) {
            self.error(results_dir_error(
                &dir,
                &doc.results_directory_loc,
                from_cli,
                &p,
            ));
            // Its setups' folders under it follow from this one.
            self.skip_results_dirs = moved_to.is_some();
        }
        // The study's setups and its force sweeps' setups, each checked on
        // its own whatever the study's problems.
        let mut files = doc.setup_files.clone();
        for p in &doc.sweep_setup_files {
            if !files.contains(p) {
                files.push(p.clone());
            }
        }
        let unknown_before = self.unknown.len();
        for s in &files {
            // With `-o DIR` each setup writes to DIR/<its folder's name>.
            let out = moved_to.map(|o| (o.to_path_buf(), false));
            self.setup_in(s, out, moved_to.is_some());
        }
        let misread = misread || self.unknown.len() > unknown_before;
        // Unknown elements were reported above: read on past them here.
        match crate::plan::StudyPlan::from_document(doc, true) {
            Ok(plan) if misread => {
                let _ = plan;
                self.notes
                    .push(format!("{}: {REFERENCES_NOT_CHECKED}", path.display()));
            }
            Ok(plan) => {
                if let Err(e) = study::check_in(&plan, moved_to) {
                    self.error(e);
                }
            }
            Err(e) => self.error(e),
        }
        self.checked.push(path.display().to_string());
    }

    /// A setup run on its own; `out`: the `-o` folder (and true).
    fn setup(&mut self, path: &Path, out: Option<(PathBuf, bool)>) {
        self.setup_in(path, out, false)
    }

    /// A setup; `out`: its results folder when not its own (the folder,
    /// whether the command line named it); `moved`: `out` is the study's
    /// `-o` folder, under which the setup writes to a folder of its own.
    fn setup_in(&mut self, path: &Path, out: Option<(PathBuf, bool)>, moved: bool) {
        self.checked.push(path.display().to_string());
        let misread = match unknown_elements(path) {
            Ok(unknown) => self.unknown(unknown),
            Err(e) => {
                self.error(e);
                return;
            }
        };
        // Every missing file at once (reading the setup stops at the first).
        match missing_input_files(path) {
            Ok(missing) if !missing.is_empty() => {
                for e in missing {
                    self.error(e);
                }
                return;
            }
            Ok(_) => {}
            Err(e) => {
                self.error(e);
                return;
            }
        }
        // Unknown elements were reported above: read on past them here.
        let setup = match Setup::read_with(path, true) {
            Ok(s) => s,
            Err(e) => {
                self.error(e);
                return;
            }
        };
        let (own, loc, name) = match &setup {
            Setup::Analyze(a) => (&a.results_directory, &a.results_directory_loc, &a.name),
            Setup::InverseDynamics(i) => (&i.results_directory, &i.results_directory_loc, &i.name),
        };
        let (dir, from_cli) = match out {
            Some((o, _)) if moved => (study::moved_results_dir(own, name, Some(&o)), false),
            Some((o, cli)) => (o, cli),
            None => (own.clone(), false),
        };
        if let Some(p) = results_dir_problem(&dir).filter(|_| !self.skip_results_dirs) {
            self.error(results_dir_error(&dir, loc, from_cli, &p));
        }
        match setup {
            Setup::Analyze(mut a) => {
                a.set_reduce_model(a.reduce_model || self.reduce);
                self.analyze(&a, &dir, misread);
            }
            Setup::InverseDynamics(i) => self.inverse_dynamics(&i),
        }
    }

    fn analyze(&mut self, setup: &AnalyzeSetup, dir: &Path, misread: bool) {
        if misread {
            if !setup.figures.is_empty() {
                self.notes.push(format!(
                    "{}: {REFERENCES_NOT_CHECKED}",
                    setup.setup_file.display()
                ));
            }
        } else {
            for e in figure_reference_problems(setup, dir) {
                self.error(e);
            }
        }
        let am = match loading::load_analysis_model(setup) {
            Ok(am) => am,
            Err(e) => {
                self.error(e);
                return;
            }
        };
        self.warnings.extend(am.warnings.iter().cloned());
        let motion = match inputs::read_motion(setup) {
            Ok(m) => Some(m),
            Err(e) => {
                self.error(e);
                None
            }
        };
        if let Some(motion) = &motion {
            match inputs::open_motion_stream(setup, motion, &am.model, &[]) {
                Ok(stream) => {
                    self.warnings.extend(stream.motion_warnings(&[]));
                    self.warnings
                        .extend(inputs::missing_columns_warning(setup, &stream.missing));
                }
                Err(e) => self.error(e),
            }
        }
        if !setup.analyses.iter().any(|a| a.common().on) {
            self.error(Error::input(
                Location::file(&setup.setup_file).with_element("<AnalysisSet>"),
                "the setup has no analysis that is on",
            ));
        }
        let has_so = setup.static_optimization().is_some();
        let coupled = inputs::coupled_reactions(&setup.analyses, has_so);
        for a in &setup.analyses {
            match a {
                Analysis::StaticOptimization(so) if so.common.on => {
                    // With <reduce_model> or --reduce, the reduced model the
                    // run would solve on.
                    let am = match (&motion, setup.reduce_model) {
                        (Some(motion), true) => match crate::tools::reduce::reduce(
                            setup,
                            motion,
                            &am,
                            so.common.step_interval,
                            so.passive_fiber_forces,
                            &coupled,
                        ) {
                            Ok((reduced, _)) => reduced,
                            Err(e) => {
                                self.error(e);
                                continue;
                            }
                        },
                        _ => am.clone(),
                    };
                    match static_optimization::SoProblem::build_from(setup, so, am) {
                        Ok((problem, w)) => {
                            self.warnings.extend(w);
                            for e in contacts_facing_away(setup, &problem) {
                                self.error(e);
                            }
                        }
                        Err(e) => self.error(e),
                    }
                }
                // Without a forces file the reactions come from the setup's own
                // static optimization (checked above); a forces file from an
                // earlier run need not exist yet.
                Analysis::JointReaction(jr)
                    if jr.forces_file.as_ref().is_some_and(|f| f.exists()) =>
                {
                    if let Err(e) = joint_reaction::JointReactionProblem::build(setup, jr) {
                        self.error(e);
                    }
                }
                Analysis::Kinematics(k) if k.common().on => {
                    if let Err(e) = crate::tools::kinematics::check(&am, k) {
                        self.error(e);
                    }
                }
                Analysis::Unsupported { element, common } if common.on => {
                    self.error(element.error(format!(
                        "the analysis '{}' is not supported yet; supported: MuscleAnalysis, StaticOptimization, JointReaction, BodyKinematics, PointKinematics",
                        element.name
                    )));
                }
                _ => {}
            }
        }
    }

    fn inverse_dynamics(&mut self, setup: &InverseDynamicsSetup) {
        let (spec, model) =
            match loading::load_composed_model(&setup.model_file, &setup.artifact_files) {
                Ok(m) => m,
                Err(e) => {
                    self.error(e);
                    return;
                }
            };
        let mut w = Vec::new();
        if let Err(e) =
            crate::tools::inverse_dynamics::check_forces(&spec, &setup.forces_to_exclude, &mut w)
        {
            self.error(e);
        }
        self.warnings.extend(w);
        if let Some(p) = &setup.external_loads_file {
            let dir = setup.dir();
            if let Err(e) = crate::forces::external_loads::ExternalLoads::load(p, dir, &model) {
                self.error(e);
            }
        }
        match crate::storage::read(&setup.coordinates_file) {
            Ok(raw) => match crate::motion::checks::motion_warnings(
                &model,
                &setup.coordinates_file,
                &raw.labels,
                &crate::motion::checks::TimeSteps::of(&raw.time),
                setup.lowpass_cutoff,
            ) {
                Ok(w) => self.warnings.extend(w),
                Err(e) => self.error(e),
            },
            Err(e) => self.error(e),
        }
    }
}

/// The contacts of `problem` whose plane faces away from their point's
/// body at the first frame of the motion (the model's default pose when the
/// motion cannot be read): `contacts::facing::facing_away_at_start`, each
/// named with the contact's file and line (its element among `forces`):
/// `--check`'s errors for a compiled problem.
pub fn contacts_facing_away(
    setup: &AnalyzeSetup,
    problem: &static_optimization::SoProblem,
) -> Vec<Error> {
    if problem.contacts.is_empty() {
        return Vec::new();
    }
    let model = &problem.model;
    let block = inputs::open_state_stream_with(setup, model, &problem.contacts)
        .and_then(|mut s| s.next_block());
    let first = match &block {
        Ok(Some(b)) if !b.q.is_empty() => Some((b.time[0], b.q[0].as_slice())),
        _ => None,
    };
    crate::contacts::facing::facing_away_at_start(model, &problem.contacts, first)
}
