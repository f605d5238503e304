//! OpenSim's JointReaction analysis (opensim-semantics.md §7;
//! `OpenSim/Analyses/JointReaction.cpp`, Simbody's
//! `calcMobilizerReactionForces`).
//!
//! Per frame:
//! 1. every actuator gets its force from `forces_file` (linear interpolation
//!    in time, §7.2): a muscle's tension is applied along its path as point
//!    forces on the bodies, a CoordinateActuator as a generalized force,
//!    Point/TorqueActuators as body forces; external loads and passive forces
//!    are evaluated at the state;
//! 2. accelerations come from **forward dynamics** with those forces and the
//!    model's constraints (locked/prescribed coordinates, couplers): the
//!    reduced system `Cᵀ M C y = −Cᵀ τ(d)`, u̇ = d + C y, C the coupling
//!    vectors of the independent coordinates, d the constrained accelerations
//!    at y = 0;
//! 3. the reaction of each joint is Simbody's "free-body" reaction: what the
//!    child's subtree needs (Σ M a + gyroscopic − applied *body* forces),
//!    i.e. the RNEA's transmitted spatial force, referred to the child joint
//!    frame origin M_o. Applied *mobility* forces (CoordinateActuators,
//!    limit forces, moving-path-point terms, constraint mobility forces) are
//!    therefore included in the reaction, as Simbody documents. The parent
//!    case is −F shifted to the parent joint frame origin F_o.
//!
//! Output: `<name>_<analysis>_ReactionLoads.sto`, storage `Joint Reaction
//! Loads`, nine columns per joint `<joint>_on_<body>_in_<frame>_{fx,fy,fz,
//! mx,my,mz,px,py,pz}` (§1.5): force and moment (about M_o or F_o) and the
//! point's location, all in the frame E.
//!
//! Differences from OpenSim, by design: a `forces_file` missing any actuator
//! (or no `forces_file` at all while the model has actuators) is an error
//! naming the actuators, where OpenSim silently computes meaningless forces
//! from default muscle states; actuators are read by column name, where
//! OpenSim reads only the first n_act columns (a warning says when that
//! would differ); actuators with `appliesForce=false` need no column.

use std::path::{Path, PathBuf};

use crate::error::{Error, Location, Result};
use crate::forces::actuators::Actuator;
use crate::forces::external_loads::ExternalLoads;
use crate::forces::passive::PassiveForce;
use crate::frame::workspace::Workspace;
use crate::model::{Model, Transform};
use crate::motion::states::assemble;
use crate::muscles::set::MuscleSet;
use crate::parse::setup::{resolve, AnalysisCommon, AnalyzeSetup};
use crate::storage::{self, StoWriter, Storage};
use crate::tools::analyze::{for_each_frame, is_frame, open_state_stream, results_dir};
use crate::tools::loading::{applies_force, force_kind, load_analysis_model, ForceKind};
use crate::tools::static_optimization::Control;
use crate::tools::{RunOptions, RunSummary};
use crate::xml::Element;

// Reactions of a frame are the `reactions` stage; these paths stay for users.
pub use crate::reactions::joint::{
    apply_forces, column_labels, forward_dynamics, reactions, reactions_at_accelerations,
    static_optimization_reactions, ReactionSpec,
};

/// OpenSim's storage description (`JointReaction::constructDescription`).
pub const DESCRIPTION: &str = "\nThis file contains the reaction forces and moments\napplied to the specified body of a joint pair and expressed  in the specified reference frame.\n\nUnits are S.I. units (seconds, meters, Newtons, ...)";

/// The JointReaction element of an AnalyzeTool setup (§7.1).
#[derive(Debug, Clone)]
pub struct JointReactionSetup {
    pub common: AnalysisCommon,
    /// Resolved against the setup's folder; None when empty.
    pub forces_file: Option<PathBuf>,
    pub joint_names: Vec<String>,
    pub apply_on_bodies: Vec<String>,
    pub express_in_frame: Vec<String>,
    /// statopt `<knee_loads>`: also write `<prefix>KneeLoads.sto`
    /// (`tools::knee_loads`) with each ReactionLoads table of a static
    /// optimization run.
    pub knee_loads: bool,
    /// The element, for located errors.
    pub element: Element,
}

impl JointReactionSetup {
    pub fn from_xml(
        el: &Element,
        common: AnalysisCommon,
        setup_dir: &std::path::Path,
    ) -> Result<Self> {
        let list = |name: &str, default: &str| -> Vec<String> {
            match el.child(name).map(|c| c.words()) {
                Some(w) if !w.is_empty() => w,
                _ => vec![default.to_string()],
            }
        };
        let forces_file = el
            .child_text("forces_file")
            .map(str::trim)
            .filter(|s| !s.is_empty() && *s != "Unassigned")
            .map(|s| resolve(setup_dir, s));
        Ok(JointReactionSetup {
            common,
            forces_file,
            joint_names: list("joint_names", "ALL"),
            apply_on_bodies: list("apply_on_bodies", "child"),
            express_in_frame: list("express_in_frame", "ground"),
            knee_loads: el.child_bool_or("knee_loads", false)?,
            element: el.clone(),
        })
    }
}

/// Resolve joint_names / apply_on_bodies / express_in_frame as
/// `JointReaction::setupReactionList` does (§7.1). Unknown joints are
/// skipped with a warning; a bad body keyword or frame name is an error.
pub fn resolve_reactions(
    model: &Model,
    jr: &JointReactionSetup,
) -> Result<(Vec<ReactionSpec>, Vec<String>)> {
    let el = &jr.element;
    let at = |prop: &str| el.child(prop).unwrap_or(el);
    let mut warnings = Vec::new();
    let set: Vec<usize> = model
        .joint_set_order
        .iter()
        .copied()
        .filter(|&b| b != 0)
        .collect();
    let names: Vec<String> = if jr.joint_names[0].eq_ignore_ascii_case("ALL") {
        set.iter().map(|&b| model.joints[b].name.clone()).collect()
    } else {
        jr.joint_names.clone()
    };
    let n = names.len();
    for (prop, v) in [
        ("apply_on_bodies", &jr.apply_on_bodies),
        ("express_in_frame", &jr.express_in_frame),
    ] {
        if v.len() != 1 && v.len() != n {
            return Err(at(prop).error(format!(
                "{prop} has {} entries; it must have 1 or one per joint ({n})",
                v.len()
            )));
        }
    }
    let mut specs = Vec::new();
    // OpenSim's JointSet::getIndex(name, start): search from start, wrapping.
    let mut last: Option<usize> = None;
    for (i, name) in names.iter().enumerate() {
        let start = last.map(|l| l + 1).unwrap_or(0);
        let found = (0..set.len())
            .map(|k| (start + k) % set.len().max(1))
            .find(|&k| model.joints[set[k]].name == *name);
        let Some(k) = found else {
            warnings.push(format!(
                "JointReaction '{}': '{name}' is not a joint of the model; ignored",
                jr.common.name
            ));
            continue;
        };
        last = Some(k);
        let b = set[k];
        let joint = &model.joints[b];
        let on = if jr.apply_on_bodies.len() == 1 {
            &jr.apply_on_bodies[0]
        } else {
            &jr.apply_on_bodies[i]
        };
        let on_child = match on.to_ascii_lowercase().as_str() {
            "child" => true,
            "parent" => false,
            _ => {
                return Err(at("apply_on_bodies").error(format!(
                    "apply_on_bodies entry '{on}' must be 'child' or 'parent'"
                )))
            }
        };
        let on_body = if on_child { b } else { joint.parent_body };
        let ex = if jr.express_in_frame.len() == 1 {
            &jr.express_in_frame[0]
        } else {
            &jr.express_in_frame[i]
        };
        let (frame_body, frame, frame_name) = match find_named_frame(model, ex) {
            Some(f) => (f.body, f.transform, f.name.clone()),
            None => {
                let body = match ex.to_ascii_lowercase().as_str() {
                    "child" => b,
                    "parent" => joint.parent_body,
                    _ => {
                        return Err(at("express_in_frame").error(format!(
                            "express_in_frame entry '{ex}' is neither a frame of the model nor 'child' or 'parent'"
                        )))
                    }
                };
                (body, Transform::identity(), model.bodies[body].name.clone())
            }
        };
        specs.push(ReactionSpec {
            joint: b,
            on_child,
            frame_body,
            frame,
            label_root: format!(
                "{}_on_{}_in_{frame_name}",
                joint.name, model.bodies[on_body].name
            ),
        });
    }
    Ok((specs, warnings))
}

/// A frame named as OpenSim's JointReaction looks it up: a path relative to
/// the model, then to the BodySet, then to the JointSet.
fn find_named_frame<'m>(model: &'m Model, name: &str) -> Option<&'m crate::model::Frame> {
    let rel = name.trim_start_matches("./");
    let candidates = if rel.starts_with('/') {
        vec![rel.to_string()]
    } else {
        vec![
            format!("/{rel}"),
            format!("/bodyset/{rel}"),
            format!("/jointset/{rel}"),
        ]
    };
    candidates
        .iter()
        .find_map(|p| model.frames.iter().find(|f| &f.path == p))
}

/// Values of the data columns `cols` at time `t` as OpenSim's
/// `Storage::getDataAtTime`: linear interpolation between the last row with
/// time ≤ t and the next one (the last two rows beyond the end, the first
/// two before the start: linear extrapolation); rows closer than machine
/// epsilon in time give the first row's values.
pub fn values_at_time(st: &Storage, t: f64, cols: &[usize]) -> Vec<f64> {
    values_at_time_in(st, t, cols, false)
}

/// [`values_at_time`]; `sorted`: the times never decrease (checked once by
/// the caller), so the row is found by bisection instead of a scan of the
/// whole table (a scan per frame made a long trial quadratic: 100,000 rows
/// took 4.2 s).
pub fn values_at_time_in(st: &Storage, t: f64, cols: &[usize], sorted: bool) -> Vec<f64> {
    let n = st.time.len();
    // The last row with time <= t (0 if none).
    let i = if sorted {
        st.time.partition_point(|&x| x <= t).saturating_sub(1)
    } else {
        st.time.iter().rposition(|&x| x <= t).unwrap_or(0)
    };
    let (mut i1, mut i2) = (i, i + 1);
    if i2 >= n {
        i1 = i1.saturating_sub(1);
        i2 = n - 1;
    }
    let (t1, t2) = (st.time[i1], st.time[i2]);
    let den = t2 - t1;
    let pct = if den < f64::EPSILON {
        0.0
    } else {
        (t - t1) / den
    };
    cols.iter()
        .map(|&j| {
            let (y1, y2) = (st.rows[i1][j], st.rows[i2][j]);
            if pct == 0.0 {
                y1
            } else {
                y1 + pct * (y2 - y1)
            }
        })
        .collect()
}

/// A JointReaction's forces file, read as the frames need it: only the rows
/// around the frames being computed are held (the frame loop moves the
/// window forward a block at a time, [`ForcesFile::prepare`]; memory does
/// not grow with the trial). The storage reader refuses times that go back,
/// so the row for a time is found by bisection. Values are
/// [`values_at_time`]'s.
pub struct ForcesFile {
    /// None: no forces file (a model without actuators).
    path: Option<PathBuf>,
    window: std::sync::RwLock<ForcesWindow>,
}

/// The rows of a forces file held, and where the next ones come from.
struct ForcesWindow {
    /// The header and rows `offset..` of the file.
    table: Storage,
    offset: usize,
    /// The reader of the rows after the window (None: all read).
    reader: Option<storage::RowReader>,
}

impl ForcesFile {
    /// No forces file.
    pub fn none() -> Self {
        Self::with(None, Storage::default())
    }

    /// `path`, read as the frames need it; `header` is its table without rows.
    fn streamed(path: &Path, header: Storage) -> Self {
        Self::with(Some(path.to_path_buf()), header)
    }

    fn with(path: Option<PathBuf>, header: Storage) -> Self {
        ForcesFile {
            path,
            window: std::sync::RwLock::new(ForcesWindow {
                table: header,
                offset: 0,
                reader: None,
            }),
        }
    }

    /// Hold the rows frames from `t_first` to `t_last` need: from the last
    /// row at or before `t_first` to the first after `t_last` (at least two
    /// rows, the file's last two at its end). Times must not go back from
    /// one call to the next: an earlier `t_first` starts the file over.
    pub fn prepare(&self, t_first: f64, t_last: f64) -> Result<()> {
        let Some(path) = &self.path else {
            return Ok(());
        };
        let mut guard = self.window.write().map_err(|_| poisoned())?;
        let w = &mut *guard;
        let started = w.offset > 0 || !w.table.time.is_empty();
        if !started || (w.offset > 0 && w.table.time.first().is_some_and(|&t0| t_first < t0)) {
            // (Re)start at the file's first row.
            w.table.time.clear();
            w.table.rows.clear();
            w.offset = 0;
            w.reader = Some(storage::open_rows(path)?);
        }
        if let Some(r) = w.reader.as_mut() {
            let mut row = Vec::new();
            while w.table.time.len() < 2 || w.table.time.last().is_some_and(|&t| t <= t_last) {
                match r.next_row(&mut row)? {
                    Some(t) => {
                        w.table.time.push(t);
                        w.table.rows.push(row.clone());
                    }
                    None => {
                        w.reader = None;
                        break;
                    }
                }
            }
        }
        let mut k = 0;
        while w.table.time.len() - k > 2 && w.table.time[k + 1] <= t_first {
            k += 1;
        }
        w.table.time.drain(..k);
        w.table.rows.drain(..k);
        w.offset += k;
        Ok(())
    }

    /// [`values_at_time`] of the columns `cols` at `t`.
    fn values_at(&self, t: f64, cols: &[usize]) -> Result<Vec<f64>> {
        let covered = |w: &ForcesWindow| {
            let time = &w.table.time;
            let (Some(&first), Some(&last)) = (time.first(), time.last()) else {
                return false;
            };
            (w.offset == 0 || first <= t) && (w.reader.is_none() || (last > t && time.len() >= 2))
        };
        {
            let w = self.window.read().map_err(|_| poisoned())?;
            if self.path.is_none() || covered(&w) {
                return Ok(values_at_time_in(&w.table, t, cols, true));
            }
        }
        // A frame outside the window (a caller that does not prepare).
        self.prepare(t, t)?;
        let w = self.window.read().map_err(|_| poisoned())?;
        Ok(values_at_time_in(&w.table, t, cols, true))
    }
}

fn poisoned() -> Error {
    Error::internal("the forces file's window was poisoned")
}

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
        let am = load_analysis_model(setup)?;
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
        let setup_dir = setup
            .setup_file
            .parent()
            .unwrap_or(std::path::Path::new("."));
        let loads = match &setup.external_loads_file {
            Some(p) => Some(ExternalLoads::load(p, setup_dir, &model)?),
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

pub fn run(
    setup: &AnalyzeSetup,
    el: &Element,
    common: &AnalysisCommon,
    opts: &RunOptions,
) -> Result<RunSummary> {
    let setup_dir = setup
        .setup_file
        .parent()
        .unwrap_or(std::path::Path::new("."));
    let jr = JointReactionSetup::from_xml(el, common.clone(), setup_dir)?;
    let (problem, mut warnings) = JointReactionProblem::build(setup, &jr)?;
    // States streamed block by block (motion::stream): flat memory.
    let mut stream = open_state_stream(setup, &problem.model)?;
    warnings.extend(stream.motion_warnings(&[]));
    if !stream.missing.is_empty() {
        warnings.push(format!(
            "the coordinates file lacks {:?}; they are set to 0 as OpenSim's AnalyzeTool does",
            stream.missing
        ));
    }
    let (i0, i1, step) = (stream.first_row, stream.last_row, jr.common.step_interval);
    let nframes = if i1 < i0 {
        0
    } else {
        (i0..=i1).filter(|&i| is_frame(i, i0, i1, step)).count()
    };
    let dir = results_dir(setup, opts)?;
    let path = dir.join(format!(
        "{}_{}_ReactionLoads.sto",
        setup.name, jr.common.name
    ));
    let precision = opts.precision.unwrap_or(setup.output_precision);
    let mut w = StoWriter::create_for_setup(
        &setup.setup_file,
        &path,
        "Joint Reaction Loads",
        DESCRIPTION,
        &column_labels(&problem.specs),
        precision,
        false,
    )?;
    let mut progress = crate::tools::progress::bar(
        nframes as u64,
        opts,
        &format!("{}_{}", setup.name, jr.common.name),
    );
    let start = std::time::Instant::now();
    let mut last = None;
    let completed = for_each_frame(
        &mut crate::frame::driver::PreparingLoads::new(
            WithForces {
                inner: &mut stream,
                forces: &problem.forces,
            },
            problem.loads.as_ref(),
        ),
        i0,
        i1,
        step,
        || Workspace::new(&problem.model, &problem.muscles),
        |ws, block, i| {
            Ok((
                block.time[i],
                problem.frame(block.time[i], &block.q[i], &block.u[i], ws)?,
            ))
        },
        |(t, row)| {
            w.write_row(t, &row)?;
            last = Some(t);
            progress.inc(1);
            Ok(())
        },
    )?;
    progress.finish_and_clear();
    w.finish()?;
    Ok(RunSummary {
        stopped: (!completed).then(|| (crate::tools::interrupt::requested().unwrap_or(130), last)),
        frames: nframes,
        results_dirs: path.parent().map(|d| d.to_path_buf()).into_iter().collect(),
        files: vec![path],
        warnings,
        loop_seconds: start.elapsed().as_secs_f64(),
        ..Default::default()
    })
}

/// The states' blocks, the forces file's window moved to each block's
/// times before its frames are computed.
struct WithForces<'a, S> {
    inner: &'a mut S,
    forces: &'a ForcesFile,
}

impl<S: crate::motion::stream::FrameSource> crate::motion::stream::FrameSource
    for WithForces<'_, S>
{
    fn next_block(&mut self) -> Result<Option<crate::motion::stream::StateBlock>> {
        let block = self.inner.next_block()?;
        if let Some(b) = &block {
            if let (Some(&first), Some(&last)) = (b.time.first(), b.time.last()) {
                self.forces.prepare(first, last)?;
            }
        }
        Ok(block)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dynamics::{kinematics, rnea, BodyForce, Data};
    use crate::forces::actuators::ActuatorKind;
    use crate::model::compile;
    use crate::parse::osim::ModelSpec;
    use crate::paths::coupling;
    use nalgebra::Vector3;
    use std::path::Path;

    const G: f64 = 9.80665;
    const M: f64 = 2.5;
    /// Height of the pin above the ground origin (parent offset), m.
    const H: f64 = 1.3;
    /// Mass centre of the link in its body frame.
    const C: [f64; 3] = [0.4, -0.2, 0.0];
    const I: f64 = 0.08;

    fn model_from(text: &str) -> Model {
        let root = crate::xml::parse_str(text, Path::new("test.osim")).unwrap();
        compile(&ModelSpec::from_document(&root, Path::new("test.osim")).unwrap()).unwrap()
    }

    /// A link on a pin about z at (0, H, 0); gravity `gravity`; optional
    /// extra XML inside the Model (constraints) and coordinate properties.
    fn pendulum(gravity: &str, two_links: bool, coord2: &str, extra: &str) -> Model {
        let link = |name: &str| {
            format!(
                r#"<Body name="{name}"><mass>{M}</mass><mass_center>{} {} {}</mass_center><inertia>{I} {I} {I} 0 0 0</inertia></Body>"#,
                C[0], C[1], C[2]
            )
        };
        let pin = |name: &str, parent: &str, child: &str, loc: [f64; 3], coord: &str| {
            format!(
                r#"<PinJoint name="{name}">
  <socket_parent_frame>{parent}_offset</socket_parent_frame>
  <socket_child_frame>{child}_offset</socket_child_frame>
  <coordinates><Coordinate name="{coord}">{}</Coordinate></coordinates>
  <frames>
    <PhysicalOffsetFrame name="{parent}_offset"><socket_parent>{ppath}</socket_parent><translation>{} {} {}</translation><orientation>0 0 0</orientation></PhysicalOffsetFrame>
    <PhysicalOffsetFrame name="{child}_offset"><socket_parent>/bodyset/{child}</socket_parent><translation>0 0 0</translation><orientation>0 0 0</orientation></PhysicalOffsetFrame>
  </frames>
</PinJoint>"#,
                if coord == "q2" { coord2 } else { "" },
                loc[0],
                loc[1],
                loc[2],
                ppath = if parent == "ground" {
                    "/ground".to_string()
                } else {
                    format!("/bodyset/{parent}")
                }
            )
        };
        let (bodies, joints) = if two_links {
            (
                link("link") + &link("link2"),
                pin("pin", "ground", "link", [0.0, H, 0.0], "q")
                    + &pin("pin2", "link", "link2", [0.8, -0.1, 0.0], "q2"),
            )
        } else {
            (
                link("link"),
                pin("pin", "ground", "link", [0.0, H, 0.0], "q"),
            )
        };
        model_from(&format!(
            r#"<?xml version="1.0"?>
<OpenSimDocument Version="40000"><Model name="p">
<gravity>{gravity}</gravity>
<BodySet name="bodyset"><objects>{bodies}</objects></BodySet>
<JointSet name="jointset"><objects>{joints}</objects></JointSet>
{extra}
</Model></OpenSimDocument>"#
        ))
    }

    fn spec(model: &Model, on_child: bool, frame: &str) -> ReactionSpec {
        let el = crate::xml::parse_str(
            &format!(
                "<JointReaction name=\"JR\"><joint_names>pin</joint_names><apply_on_bodies>{}</apply_on_bodies><express_in_frame>{frame}</express_in_frame></JointReaction>",
                if on_child { "child" } else { "parent" }
            ),
            Path::new("setup.xml"),
        )
        .unwrap();
        let common = AnalysisCommon {
            name: "JR".into(),
            on: true,
            step_interval: 1,
            in_degrees: true,
        };
        let jr = JointReactionSetup::from_xml(&el, common, Path::new(".")).unwrap();
        let (mut specs, w) = resolve_reactions(model, &jr).unwrap();
        assert!(w.is_empty());
        specs.remove(0)
    }

    fn run_frame(
        model: &Model,
        q: f64,
        u: f64,
        tau: f64,
        specs: &[ReactionSpec],
    ) -> (Data, Vec<f64>) {
        let mut data = Data::new(model);
        data.q[0] = q;
        data.u[0] = u;
        kinematics::full(model, &mut data);
        data.clear_applied();
        data.applied_gen[0] = tau;
        let mut out = vec![0.0; 9 * specs.len()];
        reactions(model, &mut data, 0.0, specs, &mut out).unwrap();
        (data, out)
    }

    fn assert_close(got: &[f64], want: &[f64], tol: f64, what: &str) {
        for (k, (g, w)) in got.iter().zip(want).enumerate() {
            assert!((g - w).abs() <= tol, "{what}[{k}]: got {g}, want {w}");
        }
    }

    #[test]
    fn hanging_pendulum_at_rest_carries_its_weight() {
        // Mass centre straight below the pin: q such that C rotated is −y.
        let model = pendulum(&format!("0 -{G} 0"), false, "", "");
        let q0 = -(C[0].atan2(-C[1])); // rotate C = (0.4, −0.2) onto −y
        let specs = [
            spec(&model, true, "ground"),
            spec(&model, false, "ground"),
            spec(&model, true, "child"),
        ];
        let (data, out) = run_frame(&model, q0, 0.0, 0.0, &specs);
        assert!(
            data.udot[0].abs() < 1e-12,
            "at rest: udot = {}",
            data.udot[0]
        );
        let w = M * G;
        // On the link at the pin: the weight held up, no moment; point M_o = (0, H, 0).
        assert_close(
            &out[0..9],
            &[0.0, w, 0.0, 0.0, 0.0, 0.0, 0.0, H, 0.0],
            1e-9,
            "child",
        );
        // On ground at F_o (the same point): the weight pulling down.
        assert_close(
            &out[9..18],
            &[0.0, -w, 0.0, 0.0, 0.0, 0.0, 0.0, H, 0.0],
            1e-9,
            "parent",
        );
        // In the link's frame (rotated by q0), at its origin, which is M_o.
        let (s, c) = q0.sin_cos();
        let f_link = [s * w, c * w, 0.0]; // R(q0)ᵀ (0, w, 0)
        assert_close(
            &out[18..27],
            &[f_link[0], f_link[1], 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
            1e-9,
            "in child",
        );
        assert_eq!(
            column_labels(&specs[..1])[0],
            "pin_on_link_in_ground_fx".to_string()
        );
        assert_eq!(specs[1].label_root, "pin_on_ground_in_ground");
        assert_eq!(specs[2].label_root, "pin_on_link_in_link");
    }

    #[test]
    fn spinning_pendulum_needs_the_centripetal_force_and_includes_mobility_torques() {
        // Gravity along the pin axis: no gravity torque, so with no applied
        // torque the link spins at constant ω and the pin supplies
        // m·a_c − m·g with a_c = −ω² c (c: mass centre relative to the pin),
        // and the moment about the pin that balances gravity's: m G (c × ẑ).
        let model = pendulum(&format!("0 0 -{G}"), false, "", "");
        let specs = [spec(&model, true, "ground"), spec(&model, false, "ground")];
        let (q, w) = (0.7, 3.0);
        for tau in [0.0, 1.7] {
            let (data, out) = run_frame(&model, q, w, tau, &specs);
            let (s, co) = q.sin_cos();
            let c = Vector3::new(co * C[0] - s * C[1], s * C[0] + co * C[1], 0.0);
            let i_zz = I + M * (C[0] * C[0] + C[1] * C[1]);
            let alpha = tau / i_zz;
            assert!(
                (data.udot[0] - alpha).abs() < 1e-12,
                "udot {} vs {alpha}",
                data.udot[0]
            );
            let a_c = -w * w * c + Vector3::z().cross(&c) * alpha;
            let f = M * a_c + Vector3::new(0.0, 0.0, M * G);
            // Moment about the pin: balances gravity's, plus the applied
            // torque delivered across the mobilizer (Simbody includes
            // mobility forces in the reaction).
            let m = M * G * c.cross(&Vector3::z()) + Vector3::new(0.0, 0.0, tau);
            let want = [f[0], f[1], f[2], m[0], m[1], m[2], 0.0, H, 0.0];
            assert_close(&out[0..9], &want, 1e-9, &format!("child, tau {tau}"));
            let want_p = [-f[0], -f[1], -f[2], -m[0], -m[1], -m[2], 0.0, H, 0.0];
            assert_close(&out[9..18], &want_p, 1e-9, &format!("parent, tau {tau}"));
        }
    }

    /// Reduced equations of motion `Cᵀ τ = 0` at the forward-dynamics accelerations.
    fn reduced_residual(model: &Model, data: &mut Data) -> f64 {
        kinematics::full(model, data);
        rnea::inverse_dynamics_after_kinematics(model, data, true);
        (0..model.nq())
            .filter(|&k| !model.coordinates[k].is_constrained())
            .map(|k| coupling::project(model, &data.q, k, &data.tau).abs())
            .fold(0.0, f64::max)
    }

    #[test]
    fn forward_dynamics_honours_locks_and_couplers() {
        // Locked second joint: it stays still, the first obeys the reduced EOM.
        let locked = pendulum(&format!("0 -{G} 0"), true, "<locked>true</locked>", "");
        let mut data = Data::new(&locked);
        data.q.copy_from_slice(&[0.4, 0.0]);
        data.u.copy_from_slice(&[1.2, 0.0]);
        kinematics::full(&locked, &mut data);
        data.clear_applied();
        forward_dynamics(&locked, &mut data, 0.0).unwrap();
        assert_eq!(data.udot[1], 0.0);
        assert!(data.udot[0].abs() > 1.0);
        assert!(reduced_residual(&locked, &mut data) < 1e-10);
        // A locked link moves as one rigid body: same as a single body whose
        // mass properties are the union (checked through energy balance is
        // overkill; the reduced EOM residual above already pins u̇₁).

        // Coupler q2 = 0.5 q1²: u̇2 = q1 u̇1 + u1² (s = 0.5, f = q²).
        let coupler = r#"<ConstraintSet name="constraintset"><objects>
<CoordinateCouplerConstraint name="c"><independent_coordinate_names>q</independent_coordinate_names>
<dependent_coordinate_name>q2</dependent_coordinate_name>
<coupled_coordinates_function><PolynomialFunction name="f"><coefficients>1 0 0</coefficients></PolynomialFunction></coupled_coordinates_function>
<scale_factor>0.5</scale_factor></CoordinateCouplerConstraint></objects></ConstraintSet>"#;
        let coupled = pendulum(&format!("0 -{G} 0"), true, "", coupler);
        assert_eq!(coupled.couplers.len(), 1);
        let mut data = Data::new(&coupled);
        let (q1, u1) = (0.6, -0.9);
        data.q.copy_from_slice(&[q1, 0.5 * q1 * q1]);
        data.u.copy_from_slice(&[u1, q1 * u1]);
        kinematics::full(&coupled, &mut data);
        data.clear_applied();
        data.applied_gen[0] = 2.0;
        forward_dynamics(&coupled, &mut data, 0.0).unwrap();
        let want = q1 * data.udot[0] + u1 * u1;
        assert!(
            (data.udot[1] - want).abs() < 1e-12,
            "{} vs {want}",
            data.udot[1]
        );
        assert!(reduced_residual(&coupled, &mut data) < 1e-10);
    }

    #[test]
    fn body_level_actuators_match_their_generalized_forces() {
        let model = pendulum(&format!("0 -{G} 0"), true, "", "");
        let mut data = Data::new(&model);
        data.q.copy_from_slice(&[0.3, -0.8]);
        kinematics::positions(&model, &mut data);
        let acts = [
            ActuatorKind::Point {
                body: 2,
                point: Vector3::new(0.1, 0.2, 0.3),
                point_is_global: false,
                direction: Vector3::new(0.0, 0.6, 0.8),
                force_is_global: false,
            },
            ActuatorKind::Torque {
                body_a: 2,
                body_b: 1,
                axis: Vector3::new(0.0, 0.0, 1.0),
                torque_is_global: true,
            },
            ActuatorKind::Coordinate { coordinate: 1 },
        ];
        for kind in acts {
            let a = Actuator {
                name: "a".into(),
                type_name: "X".into(),
                kind,
                optimal_force: 1.0,
                min_control: -1.0,
                max_control: 1.0,
                applies_force: true,
            };
            let mut want = vec![0.0; 2];
            a.add_unit_generalized_force(&model, &data, &mut want);
            let mut applied = vec![BodyForce::default(); model.nbodies()];
            let mut gen = vec![0.0; 2];
            a.apply(&data, 3.0, &mut applied, &mut gen);
            for (b, bf) in applied.iter().enumerate().skip(1) {
                let x = Vector3::zeros();
                // A spatial force (F, moment about the origin) = F at the
                // origin plus a torque.
                crate::dynamics::jacobian::add_point_force(
                    &model, &data, b, &x, &bf.force, &mut gen,
                );
                crate::dynamics::jacobian::add_body_torque(&model, &data, b, &bf.moment, &mut gen);
            }
            for k in 0..2 {
                assert!(
                    (gen[k] - 3.0 * want[k]).abs() < 1e-12,
                    "{:?}: {gen:?} vs 3×{want:?}",
                    a.kind
                );
            }
        }
    }

    /// A forces file read window by window gives the values of the whole
    /// table: frames in blocks moving forward (the window drops the rows
    /// behind), frames asked without `prepare`, times before the first row,
    /// past the last and back to the start (the file is read again).
    #[test]
    fn forces_file_window_equals_the_whole_table() {
        let dir = std::env::temp_dir().join(format!("statopt_jr_window_{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("forces.sto");
        let mut st = Storage {
            name: "forces".into(),
            labels: vec!["a".into(), "b".into()],
            ..Storage::default()
        };
        for i in 0..1000 {
            let t = 0.01 * i as f64 + if i % 7 == 0 { 0.0 } else { 0.003 };
            st.time.push(t);
            st.rows.push(vec![(3.0 * t).sin(), t * t]);
        }
        storage::write(&path, &st, 16).unwrap();
        let whole = storage::read(&path).unwrap();
        let mut pass = storage::open_rows(&path).unwrap();
        let mut row = Vec::new();
        while pass.next_row(&mut row).unwrap().is_some() {}
        let f = ForcesFile::streamed(&path, pass.table.clone());
        let check = |t: f64| {
            assert_eq!(
                f.values_at(t, &[0, 1]).unwrap(),
                values_at_time(&whole, t, &[0, 1]),
                "t = {t}"
            );
        };
        for b in 0..25 {
            let (t0, t1) = (
                -0.05 + 0.43 * b as f64,
                -0.05 + 0.43 * (b + 1) as f64 - 1e-3,
            );
            f.prepare(t0, t1).unwrap();
            for k in 0..=20 {
                check(t0 + (t1 - t0) * k as f64 / 20.0);
            }
            assert!(f.window.read().unwrap().table.time.len() < 60, "block {b}");
        }
        for t in [10.5, 0.0, -1.0, 4.995, 4.99, 7.0, 0.005] {
            check(t);
        }
    }

    #[test]
    fn forces_file_is_interpolated_as_opensim_storage() {
        let st = Storage {
            labels: vec!["a".into(), "b".into()],
            time: vec![0.0, 1.0, 1.0, 2.0],
            rows: vec![
                vec![0.0, 10.0],
                vec![1.0, 20.0],
                vec![5.0, 30.0],
                vec![7.0, 40.0],
            ],
            ..Storage::default()
        };
        assert_eq!(values_at_time(&st, 0.25, &[0, 1]), vec![0.25, 12.5]);
        // At a duplicated time: the last row with t ≤ 1 and the next.
        assert_eq!(values_at_time(&st, 1.0, &[0]), vec![5.0]);
        assert_eq!(values_at_time(&st, 1.5, &[1]), vec![35.0]);
        // Linear extrapolation at both ends.
        assert_eq!(values_at_time(&st, 3.0, &[0]), vec![9.0]);
        assert_eq!(values_at_time(&st, -1.0, &[0]), vec![-1.0]);
        // Bisection on non-decreasing times (repeated ones too) finds the
        // rows the scan finds.
        let mut st2 = st.clone();
        st2.time = vec![0.0, 0.5, 0.5, 1.0, 2.0, 2.0, 3.5];
        st2.rows = (0..7).map(|i| vec![i as f64, (i * i) as f64]).collect();
        for k in -10..50 {
            let t = k as f64 * 0.1;
            assert_eq!(
                values_at_time_in(&st2, t, &[0, 1], true),
                values_at_time(&st2, t, &[0, 1]),
                "t = {t}"
            );
        }
    }

    #[test]
    fn reaction_list_follows_opensim_rules() {
        let model = pendulum(&format!("0 -{G} 0"), true, "", "");
        let common = AnalysisCommon {
            name: "JR".into(),
            on: true,
            step_interval: 1,
            in_degrees: true,
        };
        let parse = |body: &str| {
            let el = crate::xml::parse_str(
                &format!("<JointReaction name=\"JR\">{body}</JointReaction>"),
                Path::new("setup.xml"),
            )
            .unwrap();
            let jr = JointReactionSetup::from_xml(&el, common.clone(), Path::new(".")).unwrap();
            resolve_reactions(&model, &jr)
        };
        // Defaults: all joints, on child, in ground.
        let (s, _) = parse("").unwrap();
        let roots: Vec<&str> = s.iter().map(|s| s.label_root.as_str()).collect();
        assert_eq!(roots, ["pin_on_link_in_ground", "pin2_on_link2_in_ground"]);
        // Order of joint_names, per-joint lists, keywords case-insensitive,
        // frames by body name and by joint-relative path, unknown joints skipped.
        let (s, w) = parse(
            "<joint_names>pin2 nope pin</joint_names><apply_on_bodies>PARENT child child</apply_on_bodies><express_in_frame>Child link pin2/link2_offset</express_in_frame>",
        )
        .unwrap();
        let roots: Vec<&str> = s.iter().map(|s| s.label_root.as_str()).collect();
        assert_eq!(
            roots,
            ["pin2_on_link_in_link2", "pin_on_link_in_link2_offset"]
        );
        assert_eq!(w.len(), 1);
        assert!(parse("<apply_on_bodies>child parent child</apply_on_bodies>").is_err());
        assert!(parse("<apply_on_bodies>middle</apply_on_bodies>").is_err());
        assert!(parse("<express_in_frame>nowhere</express_in_frame>").is_err());
    }
}
