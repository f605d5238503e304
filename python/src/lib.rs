//! `statopt._native`: the statopt engine in-process, for the pure-Python
//! package `statopt` (python/statopt/). Runs release the GIL; errors map to
//! `statopt.InputError` (bad input: the CLI's file/line/element message,
//! exit status 2) and `statopt.StatoptError` (anything else).

use std::path::PathBuf;
use std::sync::{Arc, Mutex};

use pyo3::create_exception;
use pyo3::exceptions::PyException;
use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyDict, PyList};

use statopt::storage::{self, Storage};
use statopt::tools::{self, progress::ProgressHook, RunOptions, RunSummary};

create_exception!(
    statopt,
    StatoptError,
    PyException,
    "A statopt run failed (the CLI's exit status 1)."
);
create_exception!(
    statopt,
    InputError,
    StatoptError,
    "The input is wrong: a setup, model, table or option. The message names the file, line and element, as the CLI's does (exit status 2); the attributes file, line, element and reason hold them apart."
);

/// A message of the engine in Python's words: the CLI's options it names
/// become the arguments of `statopt.run()` / `statopt.check()`
/// (`--allow-unknown` is `allow_unknown=True`, `-o DIR` is
/// `results_dir='DIR'`, ...).
fn python_words(text: &str) -> String {
    let mut t = text.to_string();
    // `-o DIR: the results folder ...` (create_results_dir's CLI form).
    if let Some(rest) = t.strip_prefix("-o ") {
        if let Some(k) = rest.find(": the results folder") {
            t = format!("results_dir='{}'{}", &rest[..k], &rest[k..]);
        }
    }
    for (cli, py) in [
        ("statopt-tool --check", "statopt.check()"),
        ("--allow-unknown", "allow_unknown=True"),
        (
            "run the same command again with --resume",
            "call it again with resume=True and the same results_dir",
        ),
        ("--resume", "resume=True"),
        ("--reduce", "reduce=True"),
    ] {
        t = t.replace(cli, py);
    }
    t
}

fn python_words_all(v: &[String]) -> Vec<String> {
    v.iter().map(|s| python_words(s)).collect()
}

fn to_py(py: Python<'_>, e: statopt::Error) -> PyErr {
    let text = python_words(&e.to_string());
    match e {
        statopt::Error::Input { loc, msg } => {
            let err = InputError::new_err(text);
            let v = err.value(py);
            let file = loc.file.as_ref().map(|f| f.display().to_string());
            let _ = v.setattr("file", file);
            let _ = v.setattr("line", loc.line);
            let _ = v.setattr("element", loc.element.clone());
            let _ = v.setattr("reason", python_words(&msg));
            err
        }
        statopt::Error::Internal(_) => StatoptError::new_err(text),
    }
}

fn summary_dict<'py>(py: Python<'py>, s: &RunSummary) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    let paths =
        |v: &[PathBuf]| -> Vec<String> { v.iter().map(|p| p.display().to_string()).collect() };
    d.set_item("frames", s.frames)?;
    d.set_item("solves", s.solves)?;
    d.set_item("failed", s.failed)?;
    d.set_item("first_failure", s.first_failure.clone())?;
    d.set_item("worst_residual", s.worst_residual)?;
    d.set_item("reserve_peak", s.reserve_peak.clone())?;
    d.set_item("root_force_peak", s.root_force_peak.clone())?;
    d.set_item("root_moment_peak", s.root_moment_peak.clone())?;
    d.set_item("root_body_weight", s.root_body_weight)?;
    d.set_item("loop_seconds", s.loop_seconds)?;
    d.set_item("warnings", python_words_all(&s.warnings))?;
    let contacts = PyList::empty(py);
    for f in &s.contacts {
        let c = PyDict::new(py);
        c.set_item("run", f.run.clone())?;
        c.set_item("contact", f.contact.clone())?;
        c.set_item("kind", f.kind.as_str())?;
        c.set_item("frames", f.frames)?;
        c.set_item("value", f.value)?;
        c.set_item("time", f.time)?;
        c.set_item("reserve_body", f.reserve_body.clone())?;
        c.set_item("message", python_words(&f.message))?;
        contacts.append(c)?;
    }
    d.set_item("contacts", contacts)?;
    d.set_item("notes", python_words_all(&s.notes))?;
    d.set_item("files", paths(&s.files))?;
    d.set_item("results_dirs", paths(&s.results_dirs))?;
    d.set_item("report", python_words_all(&s.report()))?;
    d.set_item("failure_line", s.failure_line())?;
    d.set_item("stopped", s.stopped_line().map(|l| python_words(&l)))?;
    Ok(d)
}

/// The error that stops a run (Ctrl-C seen by [`watched`], or an error of
/// the progress callback), kept to be raised once the run has stopped.
type Pending = Arc<Mutex<Option<PyErr>>>;

/// Keep `e` as the run's pending error (the first one holds) and ask the
/// frame loop to stop, as a signal stops the CLI
/// (`statopt::frame::interrupt`).
fn stop_with(pending: &Pending, e: PyErr) {
    let mut p = pending.lock().unwrap_or_else(|p| p.into_inner());
    if p.is_none() {
        *p = Some(e);
        statopt::frame::interrupt::request(statopt::frame::interrupt::EXIT_SIGINT);
    }
}

/// The progress hook of a run: calls `progress(label, done, total)`; an
/// error of it stops the run and is kept in the returned slot, to be
/// raised afterwards. (Ctrl-C is [`watched`]'s: the hook runs on the
/// engine's threads, where Python sees no signal.)
fn progress_hook(progress: Option<PyObject>) -> (Option<ProgressHook>, Pending) {
    let pending: Pending = Arc::new(Mutex::new(None));
    let slot = pending.clone();
    let hook = progress.map(|cb| {
        ProgressHook(Arc::new(move |label: &str, done: u64, total: u64| {
            Python::with_gil(|py| {
                if let Err(e) = cb.call1(py, (label, done, total)) {
                    stop_with(&slot, e);
                }
            })
        }))
    });
    (hook, pending)
}

/// How often a run's caller looks for Ctrl-C ([`watched`]).
const SIGNAL_CHECK: std::time::Duration = std::time::Duration::from_millis(100);

/// `work` (the engine) on a thread of its own, for the caller's run (its
/// outputs' capture, `storage::results::context`), while the calling
/// thread, without the GIL, looks for signals every [`SIGNAL_CHECK`] and
/// returns as soon as `work` ends. Python runs signal handlers on its main
/// thread only, so the engine's threads (`threads=N` runs the frame loop
/// in a pool) never see Ctrl-C: this thread, the caller's, does. Ctrl-C
/// (or any error of a signal handler) is kept in `pending` and stops the
/// frame loop at its next chunk (`statopt::frame::interrupt`), which then
/// closes every table with the frames solved, as the CLI does.
fn watched<T: Send>(py: Python<'_>, pending: &Pending, work: impl FnOnce() -> T + Send) -> T {
    let run = storage::results::context();
    py.allow_threads(|| {
        std::thread::scope(|s| {
            let (done, finished) = std::sync::mpsc::channel::<()>();
            let engine = std::thread::Builder::new()
                .name("statopt-run".into())
                // The stack of a main thread: the engine ran on the
                // caller's thread before.
                .stack_size(8 << 20)
                .spawn_scoped(s, move || {
                    let out = run.run(work);
                    let _ = done.send(());
                    out
                })
                .expect("a thread for the run");
            while let Err(std::sync::mpsc::RecvTimeoutError::Timeout) =
                finished.recv_timeout(SIGNAL_CHECK)
            {
                Python::with_gil(|py| {
                    if let Err(e) = py.check_signals() {
                        stop_with(pending, e);
                    }
                });
            }
            match engine.join() {
                Ok(out) => out,
                Err(panic) => std::panic::resume_unwind(panic),
            }
        })
    })
}

/// The error the progress hook kept, if any (the stop it asked for is
/// cleared, so that the next run is not stopped).
fn take_pending(pending: &Pending) -> Option<PyErr> {
    let e = pending.lock().unwrap_or_else(|p| p.into_inner()).take();
    if e.is_some() {
        statopt::frame::interrupt::request(0);
    }
    e
}

/// `e` (the error that stopped a run) with, when it is Ctrl-C's
/// KeyboardInterrupt, the run's word on where it stopped and what the
/// tables hold (`RunSummary::stopped_line`) as a note (PEP 678; Python
/// 3.11 and later show it under the traceback).
fn with_stop_note(
    py: Python<'_>,
    e: PyErr,
    summary: Option<&RunSummary>,
    in_memory: bool,
) -> PyErr {
    let Some(s) = summary else { return e };
    if !e.is_instance_of::<pyo3::exceptions::PyKeyboardInterrupt>(py) {
        return e;
    }
    let note = if in_memory {
        s.stopped.map(|(_, t)| {
            let at = match t {
                Some(t) => format!("after the frame at t = {}", statopt::storage::fmt_time(t)),
                None => "before the first frame".to_string(),
            };
            format!(
                "stopped {at}: {} frames solved; results_dir=None, so no table is kept (give results_dir to keep the frames solved and resume=True to go on)",
                s.frames
            )
        })
    } else {
        s.stopped_line().map(|l| python_words(&l))
    };
    if let Some(note) = note {
        let _ = e.value(py).call_method1("add_note", (note,));
    }
    e
}

/// The run's capture of its outputs (`storage::results::Capture`), which
/// knows each output's typed key: in memory (no file written) when
/// `in_memory`, with the results folder it is kept under; else the
/// capture of `results_dir` (every path when None) that the run would
/// make itself, which writes the files. Both at once is an error.
fn run_capture(
    in_memory: bool,
    results_dir: Option<PathBuf>,
) -> PyResult<(storage::results::Capture, Option<PathBuf>)> {
    use storage::results::Capture;
    if in_memory && results_dir.is_some() {
        return Err(StatoptError::new_err(
            "in_memory=True writes no file: give no results_dir",
        ));
    }
    if in_memory {
        let c = Capture::in_memory();
        let root = c.root().map(PathBuf::from);
        return Ok((c, root));
    }
    Ok((Capture::new(results_dir.as_deref()), results_dir))
}

/// The run's outputs in the summary `d` with their typed keys, from its
/// capture: `keys`, one per path of `files` (the engine's key of that
/// output, as [`key_dict`] gives it, or None for a file no key names: a
/// figure, a study's CSV); with
/// `in_memory`, `in_memory_root` and `outputs` ([`in_memory_outputs`]).
fn run_outputs(
    py: Python<'_>,
    d: &Bound<'_, PyDict>,
    s: &RunSummary,
    c: &storage::results::Capture,
    in_memory: bool,
) -> PyResult<()> {
    let keys = PyList::empty(py);
    for f in &s.files {
        match c.key_of(f) {
            Some(k) => keys.append(key_dict(py, &k)?)?,
            None => keys.append(py.None())?,
        }
    }
    d.set_item("keys", keys)?;
    if in_memory {
        in_memory_outputs(py, d, c)?;
    }
    Ok(())
}

/// Run a setup (a study, an InverseDynamicsTool or an AnalyzeTool setup) as
/// `statopt-tool SETUP` does; `text`, when given, is the setup document read
/// as if it were the file `setup`. Returns the run summary as a dict. The
/// GIL is released while the engine runs; `progress(label, done, total)` is
/// called as frame loops advance (at most every 0.1 s), and Ctrl-C stops the
/// run cleanly, with any `threads` ([`watched`]: the tables keep the frames
/// solved) and raises KeyboardInterrupt, noted with where the run stopped.
/// `external_scales`: (ExternalForce name or `*`, factor) on the external
/// loads' force and torque data (`AnalyzeSetup::set_external_load_scales`).
///
/// The summary's `keys` give the run's typed key of each of its `files`
/// ([`run_outputs`]: from the run's capture, no name taken apart). With
/// `in_memory` (no `results_dir`) the run writes no file
/// (`storage::results::Capture::in_memory`): the summary's `files` name
/// the outputs under a folder that is not created (`in_memory_root`), and
/// `outputs` holds each output, (path, key, output) in the order written:
/// a table as its parts (`read_table`'s tuple, the values its file would
/// give), any other output as its bytes.
#[pyfunction]
#[pyo3(signature = (setup, text=None, results_dir=None, precision=None, threads=None, reduce=false, resume=false, sync=false, progress=None, allow_unknown=false, in_memory=false, external_scales=Vec::new()))]
#[allow(clippy::too_many_arguments)]
fn run<'py>(
    py: Python<'py>,
    setup: PathBuf,
    text: Option<String>,
    results_dir: Option<PathBuf>,
    precision: Option<usize>,
    threads: Option<usize>,
    reduce: bool,
    resume: bool,
    sync: bool,
    progress: Option<PyObject>,
    allow_unknown: bool,
    in_memory: bool,
    external_scales: Vec<(String, f64)>,
) -> PyResult<Bound<'py, PyDict>> {
    let (hook, pending) = progress_hook(progress);
    let (capture, results_dir) = run_capture(in_memory, results_dir)?;
    let opts = RunOptions {
        results_dir,
        precision,
        verbose: false,
        threads,
        resume,
        reduce,
        sync,
        progress: hook,
        // The CLI's rule: an unknown element is an error, a warning with
        // allow_unknown (`--allow-unknown`).
        allow_unknown,
        // The summary's warnings hold what it read on past.
        read_on_hook: None,
    };
    let result = watched(py, &pending, || match (&text, external_scales.is_empty()) {
        (Some(t), true) => tools::run_setup_text(&setup, t, &opts),
        (None, true) => tools::run_setup(&setup, &opts),
        (_, false) => {
            // The loads' data scaled as they are read: a setter of the
            // plan (`external_load_scale`; no scaled copy of the file).
            let mut parsed = match &text {
                Some(t) => statopt::parse::setup::Setup::parse_with(t, &setup, allow_unknown)?,
                None => statopt::parse::setup::Setup::read_with(&setup, allow_unknown)?,
            };
            parsed.set_external_load_scales(&external_scales)?;
            tools::run_parsed(parsed, &opts)
        }
    });
    if let Some(e) = take_pending(&pending) {
        return Err(with_stop_note(py, e, result.as_ref().ok(), in_memory));
    }
    let s = result.map_err(|e| to_py(py, e))?;
    let d = summary_dict(py, &s)?;
    run_outputs(py, &d, &s, &capture, in_memory)?;
    Ok(d)
}

/// Tables a run kept in memory (`run(..., in_memory=True)`'s `outputs`),
/// each (path, bytes), read with the engine's reader as the files would
/// be read, in parallel: as [`read_tables`] returns them.
#[pyfunction]
fn parse_tables<'py>(
    py: Python<'py>,
    outputs: Vec<(PathBuf, Vec<u8>)>,
) -> PyResult<Vec<TableParts<'py>>> {
    let files: Vec<storage::TableFile> = outputs
        .into_iter()
        .map(|(p, b)| storage::TableFile::from_bytes(&p, b))
        .collect();
    let read = py.allow_threads(|| in_parallel(files.len(), |i| storage::read_file(&files[i])));
    read.into_iter().map(|r| table_parts(py, r)).collect()
}

/// `read(i)` for every i < n, on as many threads as there are cores.
fn in_parallel<T: Send>(
    n: usize,
    read: impl Fn(usize) -> statopt::Result<T> + Sync,
) -> Vec<statopt::Result<T>> {
    let workers = std::thread::available_parallelism()
        .map_or(1, |n| n.get())
        .min(n)
        .max(1);
    let mut out: Vec<Option<statopt::Result<T>>> = Vec::new();
    out.resize_with(n, || None);
    let next = std::sync::atomic::AtomicUsize::new(0);
    let slots: Vec<Mutex<&mut Option<statopt::Result<T>>>> =
        out.iter_mut().map(Mutex::new).collect();
    std::thread::scope(|s| {
        for _ in 0..workers {
            s.spawn(|| loop {
                let i = next.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                if i >= n {
                    break;
                }
                let r = read(i);
                **slots[i].lock().unwrap_or_else(|p| p.into_inner()) = Some(r);
            });
        }
    });
    drop(slots);
    out.into_iter()
        .map(|r| r.unwrap_or_else(|| Err(statopt::Error::internal("table not read"))))
        .collect()
}

fn table_parts<'py>(py: Python<'py>, r: statopt::Result<Storage>) -> PyResult<TableParts<'py>> {
    let st = r.map_err(|e| to_py(py, e))?;
    let time = f64_bytes(py, st.time.iter().copied());
    let data = f64_bytes(py, st.rows.iter().flatten().copied());
    Ok((st.name, st.labels, time, data, st.in_degrees, st.metadata))
}

/// `statopt-tool predict-grf SETUP`: ground reactions from kinematics alone.
/// Returns the run summary as a dict with the prediction under
/// `"prediction"` (agreement with the measured loads per foot and axis,
/// stance metrics, the foot contacts). `in_memory`: as [`run`]'s, no file
/// is written and `outputs` holds them.
#[pyfunction]
#[pyo3(signature = (setup, text=None, results_dir=None, threads=None, progress=None, allow_unknown=false, in_memory=false))]
#[allow(clippy::too_many_arguments)]
fn predict_grf<'py>(
    py: Python<'py>,
    setup: PathBuf,
    text: Option<String>,
    results_dir: Option<PathBuf>,
    threads: Option<usize>,
    progress: Option<PyObject>,
    allow_unknown: bool,
    in_memory: bool,
) -> PyResult<Bound<'py, PyDict>> {
    let (hook, pending) = progress_hook(progress);
    let (capture, results_dir) = run_capture(in_memory, results_dir)?;
    let opts = RunOptions {
        results_dir,
        verbose: false,
        threads,
        progress: hook,
        allow_unknown,
        ..Default::default()
    };
    let result = watched(py, &pending, || {
        tools::predict_grf::run_setup(&setup, text.as_deref(), &opts)
    });
    if let Some(e) = take_pending(&pending) {
        let summary = result.as_ref().ok().map(|p| &p.summary);
        return Err(with_stop_note(py, e, summary, in_memory));
    }
    let p = result.map_err(|e| to_py(py, e))?;
    let d = summary_dict(py, &p.summary)?;
    let pred = PyDict::new(py);
    let metrics = p
        .metrics
        .iter()
        .map(|m| {
            let x = PyDict::new(py);
            x.set_item("side", m.side.to_string())?;
            x.set_item("axis", m.axis.to_string())?;
            x.set_item("rho", m.rho)?;
            x.set_item("rmse_N", m.rmse_n)?;
            x.set_item("rmse_BW_percent", m.rmse_bw)?;
            x.set_item("peak_error_N", m.peak_error_n)?;
            Ok(x)
        })
        .collect::<PyResult<Vec<_>>>()?;
    let stance = p
        .stance
        .iter()
        .map(|st| {
            let x = PyDict::new(py);
            x.set_item("side", st.side.to_string())?;
            x.set_item("cop_error_mm", st.cop_error_mm)?;
            x.set_item("heel_strike_error_ms", st.heel_strike_error_ms)?;
            x.set_item("toe_off_error_ms", st.toe_off_error_ms)?;
            Ok(x)
        })
        .collect::<PyResult<Vec<_>>>()?;
    pred.set_item("metrics", metrics)?;
    pred.set_item("stance", stance)?;
    pred.set_item("contact_points", p.contacts.points.len())?;
    pred.set_item("floor_height", p.contacts.floor_height)?;
    pred.set_item(
        "belt_velocity",
        (p.contacts.belt_velocity.x, p.contacts.belt_velocity.z),
    )?;
    pred.set_item("treadmill", p.contacts.decision.treadmill)?;
    pred.set_item("floor_decision", p.contacts.decision.reason.clone())?;
    pred.set_item("rejected", p.rejected.clone())?;
    pred.set_item("body_weight", p.body_weight)?;
    d.set_item("prediction", pred)?;
    run_outputs(py, &d, &p.summary, &capture, in_memory)?;
    Ok(d)
}

/// A run in memory's folder name (never created) and its outputs, (path,
/// key, table parts or bytes) in the order written, in the summary `d`
/// (the key as [`key_dict`] gives it, or None: [`run_outputs`]).
fn in_memory_outputs(
    py: Python<'_>,
    d: &Bound<'_, PyDict>,
    c: &storage::results::Capture,
) -> PyResult<()> {
    let root = c.root().map(|r| r.display().to_string());
    d.set_item("in_memory_root", root)?;
    let outputs = PyList::empty(py);
    for (path, output) in c.outputs() {
        let key = match c.key_of(&path) {
            Some(k) => Some(key_dict(py, &k)?),
            None => None,
        };
        let path = path.display().to_string();
        match output {
            // A table as its values (nothing printed or parsed).
            storage::results::Output::Table(t) => {
                let st = t.table(std::path::Path::new(&path)).cloned();
                outputs.append((path, key, table_parts(py, st)?))?
            }
            storage::results::Output::Bytes(b) => {
                outputs.append((path, key, PyBytes::new(py, &b)))?
            }
        }
    }
    d.set_item("outputs", outputs)
}

/// Candidates from Python dicts: `w0`, `expressions` ({force: text}),
/// `optimal_forces` ({actuator: N}), `external_scales` ({ExternalForce
/// name or "*": factor}).
fn candidate_specs(
    candidates: &[Bound<'_, PyDict>],
) -> PyResult<Vec<statopt::plan::CandidateSpec>> {
    use statopt::plan::CandidateSpec;
    let mut specs = Vec::with_capacity(candidates.len());
    for c in candidates {
        let w0: f64 = match c.get_item("w0")? {
            Some(v) => v.extract()?,
            None => {
                return Err(pyo3::exceptions::PyValueError::new_err(
                    "every candidate needs a w0",
                ))
            }
        };
        let mut spec = CandidateSpec {
            w0,
            ..Default::default()
        };
        if let Some(e) = c.get_item("expressions")? {
            let e = e.downcast_into::<PyDict>()?;
            for (k, v) in e.iter() {
                spec.expressions.push((k.extract()?, v.extract()?));
            }
        }
        if let Some(e) = c.get_item("optimal_forces")? {
            let e = e.downcast_into::<PyDict>()?;
            for (k, v) in e.iter() {
                spec.optimal_forces.push((k.extract()?, v.extract()?));
            }
        }
        if let Some(e) = c.get_item("external_scales")? {
            let e = e.downcast_into::<PyDict>()?;
            for (k, v) in e.iter() {
                spec.external_scales.push((k.extract()?, v.extract()?));
            }
        }
        specs.push(spec);
    }
    Ok(specs)
}

fn outcome_dict<'py>(
    py: Python<'py>,
    out: statopt::sweep::SweepOutcome,
) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("metric_names", out.metric_names)?;
    d.set_item("values", out.values)?;
    d.set_item("failed", out.failed)?;
    d.set_item("frames", out.frames)?;
    d.set_item("loop_seconds", out.loop_seconds)?;
    d.set_item("warnings", out.warnings)?;
    d.set_item("iterations", out.iterations)?;
    d.set_item(
        "files",
        out.files
            .iter()
            .map(|p| p.display().to_string())
            .collect::<Vec<_>>(),
    )?;
    Ok(d)
}

/// A setup compiled and every frame assembled once, kept to solve batch
/// after batch of candidates (`statopt::sweep::Scene`).
#[pyclass(module = "statopt._native")]
struct Scene {
    inner: std::sync::Mutex<statopt::sweep::Scene>,
    threads: Option<usize>,
}

#[pymethods]
impl Scene {
    #[new]
    #[pyo3(signature = (setup, text=None, threads=None))]
    fn new(
        py: Python<'_>,
        setup: PathBuf,
        text: Option<String>,
        threads: Option<usize>,
    ) -> PyResult<Self> {
        let scene = py
            .allow_threads(|| statopt::sweep::compile_scene(&setup, text.as_deref(), threads))
            .map_err(|e| to_py(py, e))?;
        Ok(Scene {
            inner: std::sync::Mutex::new(scene),
            threads,
        })
    }

    /// Frames kept.
    #[getter]
    fn frames(&self) -> usize {
        self.inner.lock().map(|s| s.frames()).unwrap_or(0)
    }

    /// Setup and motion warnings.
    #[getter]
    fn warnings(&self) -> Vec<String> {
        self.inner
            .lock()
            .map(|s| s.warnings.clone())
            .unwrap_or_default()
    }

    /// Solve `candidates` (as `force_sweep`'s) on the kept frames.
    #[pyo3(signature = (candidates, warm=true))]
    fn run<'py>(
        &self,
        py: Python<'py>,
        candidates: Vec<Bound<'py, PyDict>>,
        warm: bool,
    ) -> PyResult<Bound<'py, PyDict>> {
        let specs = candidate_specs(&candidates)?;
        let result = py.allow_threads(|| {
            let mut scene = self
                .inner
                .lock()
                .map_err(|_| statopt::Error::internal("the scene's lock is poisoned"))?;
            statopt::sweep::run_scene(&mut scene, &specs, self.threads, warm)
        });
        outcome_dict(py, result.map_err(|e| to_py(py, e))?)
    }
}

/// A force sweep (`statopt::sweep::stream`): candidates of one
/// AnalyzeTool setup that differ only in forces, solved on one compiled
/// scene. `candidates` is a list of dicts with `w0` (a number),
/// `expressions` ({force name: Lepton text}) and `optimal_forces`
/// ({actuator name: N}); `text`, when given, is the setup document read as
/// if it were the file `setup`. With `tables`, a list of one folder per
/// candidate, each candidate's tables are written there, named as a run of
/// its own setup of one w0 names them. Ctrl-C stops it (checked every
/// tenth of a second on the caller's thread, [`watched`];
/// `statopt::frame::interrupt`). Returns
/// {"metric_names", "values" (per candidate, per metric), "failed",
/// "frames", "loop_seconds", "warnings", "files"}.
#[pyfunction]
#[pyo3(signature = (setup, candidates, text=None, threads=None, warm=true, allow_unknown=false, tables=None))]
fn force_sweep<'py>(
    py: Python<'py>,
    setup: PathBuf,
    candidates: Vec<Bound<'py, PyDict>>,
    text: Option<String>,
    threads: Option<usize>,
    warm: bool,
    allow_unknown: bool,
    tables: Option<Vec<PathBuf>>,
) -> PyResult<Bound<'py, PyDict>> {
    use statopt::sweep::stream::{self, CandidateTables, SweepOptions};
    let specs = candidate_specs(&candidates)?;
    let sweep = SweepOptions {
        warm,
        tables: tables
            .unwrap_or_default()
            .into_iter()
            .map(|dir| CandidateTables { dir, w0_tag: false })
            .collect(),
        threads,
        precision: None,
        progress: None,
    };
    // Ctrl-C: seen on this thread (`watched`), it asks the frame loop to
    // stop (`statopt::frame::interrupt`) and is raised afterwards.
    let pending: Pending = Arc::new(Mutex::new(None));
    let result = watched(py, &pending, || {
        stream::run_file(&setup, text.as_deref(), allow_unknown, &specs, &sweep)
    });
    let stopped = pending.lock().unwrap_or_else(|p| p.into_inner()).take();
    if let Some(e) = stopped {
        // The stop it asked for is cleared, so that the next run is not
        // stopped.
        statopt::frame::interrupt::request(0);
        return Err(e);
    }
    outcome_dict(py, result.map_err(|e| to_py(py, e))?)
}

fn f64_bytes<'py>(py: Python<'py>, v: impl Iterator<Item = f64>) -> Bound<'py, PyBytes> {
    let bytes: Vec<u8> = v.flat_map(|x| x.to_ne_bytes()).collect();
    PyBytes::new(py, &bytes)
}

type TableParts<'py> = (
    String,
    Vec<String>,
    Bound<'py, PyBytes>,
    Bound<'py, PyBytes>,
    bool,
    Vec<(String, String)>,
);

/// Read a .sto/.mot table with the engine's reader: (name, labels, time as
/// native-endian f64 bytes, values row by row as f64 bytes, inDegrees,
/// metadata pairs).
#[pyfunction]
fn read_table<'py>(py: Python<'py>, path: PathBuf) -> PyResult<TableParts<'py>> {
    let st = py
        .allow_threads(|| storage::read(&path))
        .map_err(|e| to_py(py, e))?;
    let time = f64_bytes(py, st.time.iter().copied());
    let data = f64_bytes(py, st.rows.iter().flatten().copied());
    Ok((st.name, st.labels, time, data, st.in_degrees, st.metadata))
}

/// [`read_table`] for several files at once, read in parallel (the tables
/// of a run, read back); the first error is raised.
#[pyfunction]
fn read_tables<'py>(py: Python<'py>, paths: Vec<PathBuf>) -> PyResult<Vec<TableParts<'py>>> {
    let read = py.allow_threads(|| in_parallel(paths.len(), |i| storage::read(&paths[i])));
    read.into_iter().map(|r| table_parts(py, r)).collect()
}

fn f64s(b: &[u8], what: &str) -> PyResult<Vec<f64>> {
    if b.len() % 8 != 0 {
        return Err(StatoptError::new_err(format!(
            "{what}: {} bytes is not a whole number of f64",
            b.len()
        )));
    }
    Ok(b.chunks_exact(8)
        .map(|c| f64::from_ne_bytes(c.try_into().expect("8 bytes")))
        .collect())
}

/// Write a table in OpenSim's legacy .sto format with the engine's writer
/// (as `statopt-tool` writes its results).
#[pyfunction]
#[pyo3(signature = (path, name, labels, time, data, in_degrees, metadata, precision))]
#[allow(clippy::too_many_arguments)]
fn write_table(
    py: Python<'_>,
    path: PathBuf,
    name: String,
    labels: Vec<String>,
    time: &[u8],
    data: &[u8],
    in_degrees: bool,
    metadata: Vec<(String, String)>,
    precision: usize,
) -> PyResult<()> {
    let time = f64s(time, "time")?;
    let data = f64s(data, "data")?;
    let n = labels.len();
    if data.len() != n * time.len() {
        return Err(StatoptError::new_err(format!(
            "{} values for {} rows of {n} columns",
            data.len(),
            time.len()
        )));
    }
    let rows = if n == 0 {
        vec![Vec::new(); time.len()]
    } else {
        data.chunks_exact(n).map(<[f64]>::to_vec).collect()
    };
    let st = Storage {
        name,
        labels,
        time,
        rows,
        in_degrees,
        metadata,
    };
    py.allow_threads(|| storage::write(&path, &st, precision))
        .map_err(|e| to_py(py, e))
}

/// `statopt-tool --check SETUP [-o DIR] [--reduce] [--allow-unknown]`:
/// read and compile everything the setup names without running, as the
/// run with those options would; returns (errors, warnings, notes, files
/// checked), in Python's words.
#[pyfunction]
#[pyo3(signature = (setup, results_dir=None, reduce=false, allow_unknown=false))]
#[allow(clippy::type_complexity)]
fn check(
    py: Python<'_>,
    setup: PathBuf,
    results_dir: Option<PathBuf>,
    reduce: bool,
    allow_unknown: bool,
) -> (Vec<String>, Vec<String>, Vec<String>, Vec<String>) {
    let opts = RunOptions {
        results_dir,
        reduce,
        allow_unknown,
        ..Default::default()
    };
    let r = py.allow_threads(|| tools::check::run_with(&setup, &opts));
    (
        r.errors
            .iter()
            .map(|e| python_words(&e.to_string()))
            .collect(),
        python_words_all(&r.warnings),
        python_words_all(&r.notes),
        r.checked,
    )
}

/// The setups a document holds, read as the engine reads them: a tool
/// setup (from `text` when given), or a study's setups.
fn analyze_setups(
    setup: &std::path::Path,
    text: Option<&str>,
) -> statopt::Result<Vec<statopt::parse::setup::AnalyzeSetup>> {
    use statopt::parse::setup::Setup;
    let setups = match text {
        Some(t) => vec![Setup::parse_with(t, setup, true)?],
        None => match statopt::plan::Plan::read(setup, true)? {
            statopt::plan::Plan::Tool(s) => vec![*s],
            statopt::plan::Plan::Study(st) => st.runs.into_iter().map(|r| r.setup).collect(),
        },
    };
    Ok(setups
        .into_iter()
        .filter_map(|s| match s {
            Setup::Analyze(a) => Some(a),
            Setup::InverseDynamics(_) => None,
        })
        .collect())
}

/// A key as Python sees it: `setup`, `analysis` (None: the setup's own),
/// `w0` (a float, or None), `stat` (`mean`, `min`, `max` or None), `table`
/// (`activation`, `KneeLoads`, `MomentArm_knee_angle_r`, ...).
fn key_dict<'py>(
    py: Python<'py>,
    key: &statopt::writers::names::OutputKey,
) -> PyResult<Bound<'py, PyDict>> {
    use statopt::writers::names::Sweep;
    let d = PyDict::new(py);
    d.set_item("setup", &key.run.setup)?;
    d.set_item("analysis", key.run.analysis.clone())?;
    let (w0, stat) = match key.run.sweep {
        Sweep::Single => (None, None),
        Sweep::Weight(w) => (Some(w), None),
        Sweep::Stat(s) => (None, Some(s.as_str())),
    };
    d.set_item("w0", w0)?;
    d.set_item("stat", stat)?;
    d.set_item("table", key.kind.table())?;
    Ok(d)
}

/// `values` (a setup's figure and metric references) pointed at the
/// tables of a run of one w0: each that names a table of a w0 sweep of the
/// setup `text` (its weights' or statistics') names the same table of the
/// single run, its folder kept; others are returned as they are (and
/// all of them when the setup cannot be read: the run then says why).
#[pyfunction]
fn single_w0_references(setup: PathBuf, text: String, values: Vec<String>) -> Vec<String> {
    use statopt::writers::names::{file_name, Planned, Sweep};
    let Ok(setups) = analyze_setups(&setup, Some(&text)) else {
        return values;
    };
    let planned: Vec<Planned> = setups.iter().map(Planned::of).collect();
    values
        .into_iter()
        .map(|v| {
            let path = std::path::Path::new(&v);
            let name = path.file_name().and_then(|n| n.to_str()).unwrap_or("");
            match planned.iter().find_map(|p| p.find(name)) {
                Some(k) if k.run.sweep != Sweep::Single => {
                    let single = k.run.with_sweep(Sweep::Single).key(k.kind.clone());
                    let folder = &v[..v.len() - name.len()];
                    format!("{folder}{}", file_name(&single))
                }
                _ => v,
            }
        })
        .collect()
}

/// The name of a run's table: `setup`, `analysis` (None: the setup's
/// own), `w0` or `stat` (none: a single-w0 run) and `table`, one of
/// [`output_tables`] (`writers::names::file_name`).
#[pyfunction]
#[pyo3(signature = (setup, table, analysis=None, w0=None, stat=None))]
fn output_name(
    setup: &str,
    table: &str,
    analysis: Option<&str>,
    w0: Option<f64>,
    stat: Option<&str>,
) -> PyResult<String> {
    use statopt::writers::names::{file_name, OutputKind, RunKey, Stat, Sweep};
    let sweep = match (w0, stat) {
        (None, None) => Sweep::Single,
        (Some(w), None) => Sweep::Weight(w),
        (None, Some(s)) => {
            Sweep::Stat(*Stat::ALL.iter().find(|x| x.as_str() == s).ok_or_else(|| {
                pyo3::exceptions::PyValueError::new_err(format!(
                    "stat: one of mean, min, max, not '{s}'"
                ))
            })?)
        }
        (Some(_), Some(_)) => {
            return Err(pyo3::exceptions::PyValueError::new_err(
                "give w0 or stat, not both",
            ))
        }
    };
    let kind = OutputKind::SO_TABLES
        .into_iter()
        .chain([
            OutputKind::ReactionLoads,
            OutputKind::KneeLoads,
            OutputKind::KneeContact,
        ])
        .find(|k| k.table() == table)
        .ok_or_else(|| {
            pyo3::exceptions::PyValueError::new_err(format!(
                "table: one of {}, not '{table}'",
                output_tables().join(", ")
            ))
        })?;
    let run = RunKey {
        setup: setup.to_string(),
        analysis: analysis.map(String::from),
        sweep,
    };
    Ok(file_name(&run.key(kind)))
}

/// The tables a static-optimization run writes, with its joint reactions'
/// and the knee contact method's (`writers::names::OutputKind`).
#[pyfunction]
fn output_tables() -> Vec<String> {
    use statopt::writers::names::OutputKind;
    OutputKind::SO_TABLES
        .into_iter()
        .chain([
            OutputKind::ReactionLoads,
            OutputKind::KneeLoads,
            OutputKind::KneeContact,
        ])
        .map(|k| k.table())
        .collect()
}

#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add("StatoptError", py.get_type::<StatoptError>())?;
    m.add("InputError", py.get_type::<InputError>())?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add("DEFAULT_PRECISION", storage::DEFAULT_PRECISION)?;
    m.add_function(wrap_pyfunction!(run, m)?)?;
    m.add_function(wrap_pyfunction!(predict_grf, m)?)?;
    m.add_function(wrap_pyfunction!(force_sweep, m)?)?;
    m.add_class::<Scene>()?;
    m.add_function(wrap_pyfunction!(read_table, m)?)?;
    m.add_function(wrap_pyfunction!(read_tables, m)?)?;
    m.add_function(wrap_pyfunction!(parse_tables, m)?)?;
    m.add_function(wrap_pyfunction!(write_table, m)?)?;
    m.add_function(wrap_pyfunction!(check, m)?)?;
    m.add_function(wrap_pyfunction!(single_w0_references, m)?)?;
    m.add_function(wrap_pyfunction!(output_name, m)?)?;
    m.add_function(wrap_pyfunction!(output_tables, m)?)?;
    Ok(())
}
