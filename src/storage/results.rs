//! A run's results in memory: every output a run writes while a
//! [`Capture`] covers its path is kept as the exact bytes the file gets
//! (tables: what [`super::StoWriter`] formatted, rounded to the run's
//! precision, `nRows=` final), keyed by the output's typed key in its folder
//! ([`OutputId`]: `storage::key::OutputKey`, the key its name was made
//! from, [`name`]), or by its path when no key names it. Files are one sink
//! of them: a capture that writes no files ([`Capture::in_memory`]) keeps the
//! outputs in memory only and no file is created.
//!
//! The run's own consumers (a w0 sweep's statistics, a JointReaction that
//! takes this run's forces file, the knee tables, a study's figures and
//! metrics, the Python binding) take the outputs from here:
//! [`super::read`] and [`super::open_rows`] of a path this run wrote parse
//! the kept bytes with the file reader's own code (so the values are the
//! file's, bit for bit) and open no file. `--resume` reads what an earlier
//! run left on the disk: that is the one reading of earlier output.
//!
//! Memory: a capture in memory only keeps every output it covers until it
//! ends (they are the run's result; there is no file to fall back on). A
//! capture that writes files keeps only the outputs a consumer of this run
//! will read, as the run's plan declares them ([`want`]), and drops each
//! once its last consumer has read it ([`done`]): the other outputs are in
//! their files only. It keeps at most [`KEPT_LIMIT`] bytes (as a motion
//! file is held up to `storage::IN_MEMORY_LIMIT`): a table that would pass
//! it is not kept, and its consumers read its file, so that memory stays
//! bounded however long the trial.

use std::collections::HashMap;
use std::path::{Component, Path, PathBuf};
use std::sync::atomic::{AtomicI64, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};

use super::key::OutputKey;

use crate::error::{Error, Result};

/// One output's bytes, shared by its readers.
pub type Bytes = Arc<Vec<u8>>;

/// One kept output: a table as its values, or the bytes of any other
/// output (an XML document, a CSV, a report, a figure).
#[derive(Clone, Debug)]
pub enum Output {
    Table(Arc<KeptTable>),
    Bytes(Bytes),
}

impl Output {
    /// The memory the output holds, in bytes (a table: its values and
    /// times, 8 bytes each).
    pub fn size(&self) -> u64 {
        match self {
            Output::Table(t) => t.size(),
            Output::Bytes(b) => b.len() as u64,
        }
    }
}

/// A table a run wrote, as typed values: its header (name, labels,
/// metadata, as [`super::read`] gives them from the file) and its rows of
/// f64, each value the one the file prints ([`as_printed`]: the writer's
/// value rounded to the table's precision, as the reader would parse the
/// printed digits), built as the writer formats each row; nothing is
/// parsed. What the reader would refuse in the file (a value that is not
/// finite, a time that does not increase) is refused when it is read.
#[derive(Debug, Clone, PartialEq)]
pub struct KeptTable {
    table: super::Storage,
    /// The line of the file the first data row is on.
    first_line: usize,
    precision: usize,
    /// The first row the reader would refuse: its line, column and what.
    refused: Option<(usize, Option<String>, String)>,
}

impl KeptTable {
    /// A table with the header of `head` (a table file's bytes up to and
    /// including its label line, `nRows=` 0) and no rows yet.
    pub(super) fn new(path: &Path, head: &[u8], precision: usize) -> Result<KeptTable> {
        let table = super::read::read_text(path, head)?;
        let first_line = head.iter().filter(|&&b| b == b'\n').count() + 1;
        Ok(KeptTable {
            table,
            first_line,
            precision,
            refused: None,
        })
    }

    /// A table already holding `table`'s rows (a resumed table's, read
    /// from its file) whose first data row is on line `first_line`.
    pub(super) fn resumed(table: super::Storage, first_line: usize, precision: usize) -> KeptTable {
        KeptTable {
            table,
            first_line,
            precision,
            refused: None,
        }
    }

    /// The memory one row of `n` values takes.
    pub(super) fn row_size(n: usize) -> usize {
        8 * (n + 1) + std::mem::size_of::<Vec<f64>>()
    }

    pub(super) fn size(&self) -> u64 {
        let n = self.table.labels.len();
        (self.table.len() * Self::row_size(n)) as u64
    }

    /// Append a row, its values as the file prints them.
    pub(super) fn push(&mut self, t: f64, values: &[f64]) {
        let p = self.precision;
        let t = as_printed(t, p);
        let row: Vec<f64> = values.iter().map(|&v| as_printed(v, p)).collect();
        if self.refused.is_none() {
            let line = self.first_line + self.table.len();
            let printed = |v: f64| super::format_c_fixed(v, 0, p);
            let labels = &self.table.labels;
            if !t.is_finite() {
                self.refused = Some((line, Some("time".into()), not_finite(&printed(t))));
            } else if let Some(j) = row.iter().position(|v| !v.is_finite()) {
                self.refused = Some((line, Some(labels[j].clone()), not_finite(&printed(row[j]))));
            } else if let Some(&last) = self.table.time.last() {
                if t <= last {
                    self.refused = Some((
                        line,
                        Some("time".into()),
                        format!("time must increase from row to row, but {t} follows {last}"),
                    ));
                }
            }
        }
        self.table.time.push(t);
        self.table.rows.push(row);
    }

    /// The table, or the error the reader would give for its file.
    pub fn table(&self, path: &Path) -> Result<&super::Storage> {
        match &self.refused {
            None => Ok(&self.table),
            Some((line, column, what)) => {
                let mut at = crate::error::Location::file(path).with_line(*line);
                if let Some(c) = column {
                    at = at.with_element(format!("column '{c}'"));
                }
                Err(Error::input(at, what.clone()))
            }
        }
    }
}

/// The reader's message for a value that is not finite.
fn not_finite(token: &str) -> String {
    format!("value '{token}' is not finite (NaN/Inf are not accepted in input data)")
}

/// `x` as a table printed with `precision` decimals gives it back to its
/// reader: C `printf("%.*f")` rounds the exact binary value to `precision`
/// decimals (ties to even), and the reader parses those digits to the
/// nearest f64. Computed, not parsed: `x`·10^p exactly as the sum of two
/// f64 (a fused multiply-add gives the product's rounding error), rounded
/// to the integer N the digits spell, then N / 10^p (both exact, so the
/// quotient is the f64 nearest the printed decimal, as the reader's
/// parse). Where N or 10^p is not exact in an f64 (|x|·10^p ≥ 2^52 or
/// p > 22), the digits are printed and parsed. Not finite: `x` itself.
pub fn as_printed(x: f64, precision: usize) -> f64 {
    const POW10: [f64; 23] = [
        1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15, 1e16,
        1e17, 1e18, 1e19, 1e20, 1e21, 1e22,
    ];
    if !x.is_finite() {
        return x;
    }
    let scale = match POW10.get(precision) {
        Some(&s) => s,
        None => return slow_as_printed(x, precision),
    };
    let hi = x * scale;
    if !(hi.abs() < 4_503_599_627_370_496.0) {
        return slow_as_printed(x, precision);
    }
    // x·10^p = hi + lo exactly.
    let lo = x.mul_add(scale, -hi);
    let r = hi.round();
    // hi - r is exact (|hi| < 2^52) and in [-0.5, 0.5]; lo is below half
    // an ulp of hi, so only a distance of exactly one half is moved by it.
    let d = hi - r;
    let n = if d == 0.5 || d == -0.5 {
        // hi is a half-integer (round() took it away from zero).
        let (below, above) = if d > 0.0 { (r, r + 1.0) } else { (r - 1.0, r) };
        // hi + lo against the midpoint `below + 0.5`.
        // (On the midpoint itself, ties go to the even one.)
        if lo > 0.0 || (lo == 0.0 && below % 2.0 != 0.0) {
            above
        } else {
            below
        }
    } else {
        r
    };
    // Keep the sign of a value printed as -0.000…: the reader gives -0.0.
    let n = if n == 0.0 { 0.0f64.copysign(x) } else { n };
    n / scale
}

/// [`as_printed`] by printing the digits as the writer does and parsing
/// them.
fn slow_as_printed(x: f64, precision: usize) -> f64 {
    super::format_c_fixed(x, 0, precision).parse().unwrap_or(x)
}

/// The most bytes of tables a capture that writes files keeps: 256 MiB
/// (the leg extension study writes 54 MB of tables).
pub const KEPT_LIMIT: u64 = super::IN_MEMORY_LIMIT;

/// What a capture may still keep, in bytes, shared with the writers of
/// its tables (which take from it as they keep rows, and stop keeping
/// when it runs out).
#[derive(Clone)]
pub struct Budget(Arc<AtomicI64>);

impl Budget {
    fn new(bytes: u64) -> Budget {
        Budget(Arc::new(AtomicI64::new(bytes.min(i64::MAX as u64) as i64)))
    }

    /// Take `n` bytes; false (and nothing taken) when fewer are left.
    pub(super) fn take(&self, n: usize) -> bool {
        let n = n as i64;
        if self.0.fetch_sub(n, Ordering::Relaxed) - n < 0 {
            self.0.fetch_add(n, Ordering::Relaxed);
            return false;
        }
        true
    }

    /// Give back `n` bytes taken.
    pub(super) fn give(&self, n: usize) {
        self.0.fetch_add(n as i64, Ordering::Relaxed);
    }
}

/// One run's capture: what it covers and keeps, and the outputs kept.
struct Run {
    id: u64,
    /// The folder the capture covers (None: every path).
    root: Option<PathBuf>,
    /// Whether files are written too.
    files: bool,
    budget: Budget,
    /// Whether every output is kept (a capture in memory only: the outputs
    /// are the run's result), else only those a consumer of the run will
    /// read ([`want`]).
    keep_all: bool,
    kept: Mutex<Kept>,
}

/// An output's identity in a capture: the typed key of an output the run
/// names (`writers::names::file_name` of an [`OutputKey`]) in its folder
/// (normalised), or the normalised path of a file no key names (a figure,
/// a study's CSV, a file a user names).
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub enum OutputId {
    Keyed { dir: PathBuf, key: OutputKey },
    File(PathBuf),
}

#[derive(Default)]
struct Kept {
    /// The file names the run made from typed keys, and their keys
    /// ([`name`]): how the path a writer or reader gives is known as its
    /// key, by the names made, never by taking a name apart.
    names: HashMap<String, OutputKey>,
    /// The outputs a consumer of the run will read: how many consumers
    /// have not read it yet ([`want`], [`done`]).
    wanted: HashMap<OutputId, usize>,
    /// Outputs (normalised path, output), in the order they were finished.
    outputs: Vec<(PathBuf, Output)>,
    /// Where each output is in `outputs`, by its identity.
    index: HashMap<OutputId, usize>,
    /// Every path an output was kept at, in the order kept (those dropped
    /// since included; a path kept again after a drop twice): what the
    /// run's consumers read from memory.
    ever: Vec<PathBuf>,
}

impl Kept {
    /// The identity of the output at (normalised) `k`: its folder and the
    /// key its file name was made from, when the run made it from one.
    fn id(&self, k: &Path) -> OutputId {
        let key = k
            .file_name()
            .and_then(|n| n.to_str())
            .and_then(|n| self.names.get(n));
        match (k.parent(), key) {
            (Some(dir), Some(key)) => OutputId::Keyed {
                dir: dir.to_path_buf(),
                key: key.clone(),
            },
            _ => OutputId::File(k.to_path_buf()),
        }
    }
}

impl Run {
    fn kept(&self) -> std::sync::MutexGuard<'_, Kept> {
        self.kept.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Whether the output at (normalised) `k` is kept.
    fn keeps(&self, k: &Path) -> bool {
        if self.keep_all {
            return true;
        }
        let kept = self.kept();
        kept.wanted.contains_key(&kept.id(k))
    }
}

/// A number no other capture of the process takes (a capture's id, the
/// folder name of a capture in memory): a counter, not a registry.
static NEXT_ID: AtomicU64 = AtomicU64::new(1);

thread_local! {
    /// The captures of the runs this thread works for, innermost last: the
    /// run's context ([`Context`]). Each run owns its capture; the
    /// context only says which run a thread's work belongs to, so that two
    /// runs in one process (threads of a Python program, Dask workers)
    /// never see each other's outputs.
    static ENTERED: std::cell::RefCell<Vec<Arc<Run>>> = const { std::cell::RefCell::new(Vec::new()) };
}

/// `path` made absolute and `.`/`..` resolved by its text (no file system
/// access): the key of an output however a caller spells its folder.
fn key(path: &Path) -> PathBuf {
    let abs = std::path::absolute(path).unwrap_or_else(|_| path.to_path_buf());
    let mut out = PathBuf::new();
    for c in abs.components() {
        match c {
            Component::CurDir => {}
            Component::ParentDir => {
                out.pop();
            }
            c => out.push(c),
        }
    }
    out
}

/// The capture of this thread's run that covers the (normalised) path
/// `k`: the one whose folder is the longest start of it, else the
/// innermost that covers every path.
fn run_of(k: &Path) -> Option<Arc<Run>> {
    ENTERED.with(|e| {
        let runs = e.borrow();
        let mut best: Option<(usize, usize)> = None;
        for (i, r) in runs.iter().enumerate() {
            let depth = match &r.root {
                Some(root) if k.starts_with(root) => root.components().count() + 1,
                Some(_) => continue,
                None => 0,
            };
            if best.is_none_or(|(_, d)| depth >= d) {
                best = Some((i, depth));
            }
        }
        best.map(|(i, _)| runs[i].clone())
    })
}

/// Remove the last entry of `id` from this thread's captures.
fn leave(id: u64) {
    // (At a thread's exit the list may be gone already.)
    let _ = ENTERED.try_with(|e| {
        let mut runs = e.borrow_mut();
        if let Some(i) = runs.iter().rposition(|r| r.id == id) {
            runs.remove(i);
        }
    });
}

/// A run's capture of its outputs, owned by the run: it covers the work of
/// the thread that made it, and of the threads that work is handed to with
/// the run's [`Context`]; it ends when dropped. Not `Send`: it is dropped
/// on the thread that made it.
pub struct Capture {
    run: Arc<Run>,
    _thread: std::marker::PhantomData<*const ()>,
}

impl Capture {
    fn start(root: Option<&Path>, files: bool, limit: u64) -> Capture {
        let id = NEXT_ID.fetch_add(1, Ordering::Relaxed);
        let run = Arc::new(Run {
            id,
            root: root.map(key),
            files,
            budget: Budget::new(limit),
            keep_all: !files,
            kept: Mutex::new(Kept::default()),
        });
        ENTERED.with(|e| e.borrow_mut().push(run.clone()));
        Capture {
            run,
            _thread: std::marker::PhantomData,
        }
    }

    /// Keep the outputs written under `root` (every path, for None) that a
    /// consumer of the run will read ([`want`]) while the capture lasts
    /// (tables up to [`KEPT_LIMIT`] bytes), each until its last consumer
    /// has read it ([`done`]); files are written as well.
    pub fn new(root: Option<&Path>) -> Capture {
        Self::start(root, true, KEPT_LIMIT)
    }

    /// [`Self::new`] keeping at most `limit` bytes of tables.
    pub fn with_limit(root: Option<&Path>, limit: u64) -> Capture {
        Self::start(root, true, limit)
    }

    /// Keep the outputs of a run in memory only: a folder name that no
    /// file is created in (it is not created either). Outputs under it are
    /// kept here; a writer that would still open a file there fails (the
    /// folder does not exist) rather than leave a file behind.
    pub fn in_memory() -> Capture {
        // A number no other capture of the process takes (runs in parallel
        // threads each get a folder of their own).
        let n = NEXT_ID.fetch_add(1, Ordering::Relaxed);
        let dir = std::env::temp_dir().join(format!(
            "statopt-in-memory-{}-{n}-not-a-folder",
            std::process::id()
        ));
        Self::start(Some(&dir), false, u64::MAX)
    }

    /// The folder the capture covers (None: every path).
    pub fn root(&self) -> Option<&Path> {
        self.run.root.as_deref()
    }

    /// How many outputs the capture holds now, and their size in bytes
    /// ([`Output::size`]).
    pub fn kept(&self) -> (usize, u64) {
        let kept = self.run.kept();
        let bytes = kept.outputs.iter().map(|(_, o)| o.size()).sum();
        (kept.outputs.len(), bytes)
    }

    /// The paths of every output the capture has kept while it lasted
    /// (those dropped once read included), in the order first kept,
    /// normalised (absolute): the outputs this run's consumers wanted.
    pub fn ever_kept(&self) -> Vec<PathBuf> {
        self.run.kept().ever.clone()
    }

    /// The outputs kept so far, in the order they were finished: (path,
    /// output). The paths are normalised (absolute).
    pub fn outputs(&self) -> Vec<(PathBuf, Output)> {
        self.run.kept().outputs.clone()
    }

    /// The typed key of the output the run wrote at `path` (kept or not):
    /// the key its file name was made from (`writers::names::file_name`
    /// tells the capture, [`name`]), or None for a file no key names (a
    /// figure, a study's CSV, a table named by its setup). What the run's
    /// callers (the Python binding) hand on with each output, so that no
    /// caller takes a name apart or matches it against a plan.
    pub fn key_of(&self, path: &Path) -> Option<OutputKey> {
        match self.run.kept().id(&key(path)) {
            OutputId::Keyed { key, .. } => Some(key),
            OutputId::File(_) => None,
        }
    }

    /// The output of typed key `key` the run wrote in folder `dir`, when
    /// the capture keeps it.
    pub fn output(&self, dir: &Path, key: &OutputKey) -> Option<Output> {
        let kept = self.run.kept();
        let id = OutputId::Keyed {
            dir: self::key(dir),
            key: key.clone(),
        };
        kept.index.get(&id).map(|&i| kept.outputs[i].1.clone())
    }
}

impl Drop for Capture {
    fn drop(&mut self) {
        leave(self.run.id);
    }
}

/// The captures the current thread's work writes to and reads from: its
/// run's. Work handed to another thread (the frame loop's sinks, a worker
/// pool, a study's setups side by side) takes it along and enters it
/// there ([`Context::enter`]), so that thread's outputs are its run's.
#[derive(Clone, Default)]
pub struct Context(Vec<Arc<Run>>);

/// This thread's [`Context`].
pub fn context() -> Context {
    ENTERED.with(|e| Context(e.borrow().clone()))
}

/// While it lives, the current thread works for the context it entered.
pub struct Entered {
    ids: Vec<u64>,
    _thread: std::marker::PhantomData<*const ()>,
}

impl Context {
    /// Work for this context on the current thread until the guard is
    /// dropped.
    pub fn enter(&self) -> Entered {
        ENTERED.with(|e| e.borrow_mut().extend(self.0.iter().cloned()));
        Entered {
            ids: self.0.iter().map(|r| r.id).collect(),
            _thread: std::marker::PhantomData,
        }
    }

    /// `f` working for this context.
    pub fn run<T>(&self, f: impl FnOnce() -> T) -> T {
        let _entered = self.enter();
        f()
    }
}

impl Drop for Entered {
    fn drop(&mut self) {
        for &id in self.ids.iter().rev() {
            leave(id);
        }
    }
}

/// Whether an output at `path` is written to a file (false under a
/// capture in memory only).
pub fn writes_file(path: &Path) -> bool {
    run_of(&key(path)).is_none_or(|r| r.files)
}

/// Whether a capture of this thread's run covers `path` (it keeps the
/// outputs there that it keeps: every one, or those a consumer [`want`]s).
pub fn captured(path: &Path) -> bool {
    run_of(&key(path)).is_some()
}

/// The budget of the capture that covers `path`, when it keeps the output
/// there (None: not kept).
pub(super) fn budget(path: &Path) -> Option<Budget> {
    let k = key(path);
    run_of(&k).filter(|r| r.keeps(&k)).map(|r| r.budget.clone())
}

/// Say that a consumer of this run will read the output at `path` (the
/// plan knows which: a w0 sweep's statistics read the per-w0 tables they
/// average, a JointReaction its forces file, the knee tables the
/// ReactionLoads, a study's figures and metrics the tables they name): a
/// capture that writes files keeps only such outputs. Each call is paired
/// with one [`done`] when that consumer has read it.
pub fn want(path: &Path) {
    let k = key(path);
    if let Some(r) = run_of(&k) {
        let mut kept = r.kept();
        let id = kept.id(&k);
        *kept.wanted.entry(id).or_default() += 1;
    }
}

/// The entries of `map` of a file named `file`, keyed by `key` in their
/// folder instead (two entries of one output merged by `merge`).
fn rekey<V: Copy>(
    map: &mut HashMap<OutputId, V>,
    file: &str,
    key: &OutputKey,
    merge: impl Fn(V, V) -> V,
) {
    let named: Vec<PathBuf> = map
        .keys()
        .filter_map(|id| match id {
            OutputId::File(p) if p.file_name().and_then(|n| n.to_str()) == Some(file) => {
                Some(p.clone())
            }
            _ => None,
        })
        .collect();
    for p in named {
        let (Some(v), Some(dir)) = (map.remove(&OutputId::File(p.clone())), p.parent()) else {
            continue;
        };
        let id = OutputId::Keyed {
            dir: dir.to_path_buf(),
            key: key.clone(),
        };
        let v = match map.remove(&id) {
            Some(w) => merge(v, w),
            None => v,
        };
        map.insert(id, v);
    }
}

/// Tell this thread's runs that the file name `file` is made from the
/// typed key `key` (`writers::names::file_name` does, for every name it
/// makes): their outputs of that name are kept under the key, in their
/// folder ([`OutputId::Keyed`]; what was wanted or kept by that name
/// before is keyed so from now on). The first key said for a name holds.
pub fn name(file: &str, key: &OutputKey) {
    let _ = ENTERED.try_with(|e| {
        for r in e.borrow().iter() {
            let mut kept = r.kept();
            if kept.names.contains_key(file) {
                continue;
            }
            kept.names.insert(file.to_string(), key.clone());
            rekey(&mut kept.wanted, file, key, |a, b| a + b);
            rekey(&mut kept.index, file, key, |a, _| a);
        }
    });
}

/// A consumer that [`want`]ed the output at `path` has read it: once its
/// last consumer has, a capture that writes files drops it (its file
/// holds it).
pub fn done(path: &Path) {
    let k = key(path);
    let Some(r) = run_of(&k) else {
        return;
    };
    let mut kept = r.kept();
    let id = kept.id(&k);
    let Some(n) = kept.wanted.get_mut(&id) else {
        return;
    };
    *n = n.saturating_sub(1);
    if *n > 0 || r.keep_all {
        return;
    }
    kept.wanted.remove(&id);
    if let Some(i) = kept.index.remove(&id) {
        let (_, output) = kept.outputs.remove(i);
        r.budget.give(output.size() as usize);
        for j in kept.index.values_mut() {
            if *j > i {
                *j -= 1;
            }
        }
    }
}

/// Keep `output` as the output at `path` when a capture covers it and
/// keeps it (a later output at the same path replaces it).
pub fn keep(path: &Path, output: Output) {
    let k = key(path);
    let Some(r) = run_of(&k).filter(|r| r.keeps(&k)) else {
        return;
    };
    let mut kept = r.kept();
    let id = kept.id(&k);
    match kept.index.get(&id) {
        Some(&i) => kept.outputs[i].1 = output,
        None => {
            let i = kept.outputs.len();
            kept.index.insert(id, i);
            kept.ever.push(k.clone());
            kept.outputs.push((k, output));
        }
    }
}

/// The output this thread's run wrote at `path`, when its capture kept it.
pub fn get(path: &Path) -> Option<Output> {
    let k = key(path);
    ENTERED.with(|e| {
        e.borrow().iter().rev().find_map(|r| {
            let kept = r.kept();
            kept.index
                .get(&kept.id(&k))
                .map(|&i| kept.outputs[i].1.clone())
        })
    })
}

/// Write an output that is not a table (an XML document, a CSV, a report,
/// a figure): kept when a capture covers `path` and keeps it, and written to the file
/// unless the capture is in memory only.
pub fn write(path: &Path, bytes: Vec<u8>) -> Result<()> {
    let files = writes_file(path);
    if files {
        std::fs::write(path, &bytes).map_err(|e| Error::io(path, e))?;
    }
    if budget(path).is_some_and(|b| b.take(bytes.len())) {
        keep(path, Output::Bytes(Arc::new(bytes)));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_capture_keeps_what_is_written_under_its_folder_only() {
        let tmp = crate::test_dir::TempDir::new("results_capture");
        let tmp2 = crate::test_dir::TempDir::new("results_capture_other");
        let (dir, other) = (tmp.path().to_path_buf(), tmp2.path().to_path_buf());
        let c = Capture::new(Some(&dir));
        want(&dir.join("a.txt"));
        want(&other.join("b.txt"));
        write(&dir.join("a.txt"), b"one".to_vec()).unwrap();
        write(&other.join("b.txt"), b"two".to_vec()).unwrap();
        // Spelt another way, the same file.
        let again = dir.join("x").join("..").join("a.txt");
        let bytes = |o: Option<Output>| match o {
            Some(Output::Bytes(b)) => b,
            o => panic!("{o:?}"),
        };
        assert_eq!(bytes(get(&again)).as_slice(), b"one");
        assert!(get(&other.join("b.txt")).is_none());
        assert_eq!(std::fs::read(dir.join("a.txt")).unwrap(), b"one");
        assert_eq!(c.outputs().len(), 1);
        drop(c);
        assert!(get(&dir.join("a.txt")).is_none(), "kept past its capture");
    }

    /// The capture knows the typed key of every output the run wrote under
    /// it, kept or not, in memory or in files (the key its name was made
    /// from, said by [`name`] when the name was made); a file no key names
    /// has none.
    #[test]
    fn a_capture_knows_the_key_of_every_output_written_kept_or_not() {
        use crate::storage::key::{OutputKind, RunKey, Sweep};
        let tmp = crate::test_dir::TempDir::new("results_key_of");
        let key = |analysis: &str, sweep: Sweep, kind: OutputKind| OutputKey {
            run: RunKey {
                setup: "setup".into(),
                analysis: Some(analysis.into()),
                sweep,
            },
            kind,
        };
        let force = key("SO", Sweep::Weight(500.0), OutputKind::Force);
        let loads = key("JR", Sweep::Single, OutputKind::ReactionLoads);
        for c in [Capture::new(Some(tmp.path())), Capture::in_memory()] {
            let dir = c.root().unwrap().to_path_buf();
            // Named as `writers::names::file_name` names them.
            name("setup_SO_w0_500_force.sto", &force);
            name("setup_JR_ReactionLoads.sto", &loads);
            let wanted = dir.join("setup_JR_ReactionLoads.sto");
            want(&wanted);
            for f in [
                "setup_SO_w0_500_force.sto",
                "setup_JR_ReactionLoads.sto",
                "plot.svg",
            ] {
                write(&dir.join(f), b"x".to_vec()).unwrap();
            }
            assert_eq!(
                c.key_of(&dir.join("setup_SO_w0_500_force.sto")),
                Some(force.clone())
            );
            // Spelt another way, the same output.
            let again = dir
                .join("sub")
                .join("..")
                .join("setup_JR_ReactionLoads.sto");
            assert_eq!(c.key_of(&again), Some(loads.clone()));
            assert_eq!(c.key_of(&dir.join("plot.svg")), None);
            // Kept: every output in memory, the wanted one with files.
            assert_eq!(c.outputs().len(), if c.run.files { 1 } else { 3 });
            drop(c);
        }
    }

    #[test]
    fn a_table_past_the_limit_is_not_kept_and_read_from_its_file() {
        let tmp = crate::test_dir::TempDir::new("results_limit");
        let dir = tmp.path();
        let _c = Capture::with_limit(Some(dir), 400);
        let table = |name: &str, rows: usize| {
            let p = dir.join(name);
            want(&p);
            let mut w =
                crate::storage::StoWriter::create(&p, "t", "", &["a".to_string()], 8, false)
                    .unwrap();
            for k in 0..rows {
                w.write_row(k as f64, &[0.5]).unwrap();
            }
            w.finish().unwrap();
            p
        };
        let small = table("small.sto", 2);
        let large = table("large.sto", 40);
        assert!(get(&small).is_some());
        assert!(get(&large).is_none(), "kept past the limit");
        assert_eq!(crate::storage::read(&large).unwrap().len(), 40);
        assert_eq!(crate::storage::times_opened(&large), 1);
        assert_eq!(crate::storage::times_opened(&small), 0);
    }

    #[test]
    fn a_capture_in_memory_writes_no_file() {
        let c = Capture::in_memory();
        let root = c.root().unwrap().to_path_buf();
        let p = root.join("t.sto");
        assert!(!writes_file(&p));
        let mut w =
            crate::storage::StoWriter::create(&p, "t", "", &["a".to_string()], 8, false).unwrap();
        w.write_row(0.0, &[1.0 / 3.0]).unwrap();
        w.write_row(0.5, &[2.0]).unwrap();
        w.finish().unwrap();
        assert!(!root.exists(), "{} was created", root.display());
        let t = crate::storage::read(&p).unwrap();
        assert_eq!(t.rows, vec![vec![0.33333333], vec![2.0]]);
        assert_eq!(crate::storage::times_opened(&p), 0);
        assert_eq!(c.outputs().len(), 1);
    }

    #[test]
    fn a_capture_with_files_keeps_only_what_a_consumer_reads_until_it_has() {
        let tmp = crate::test_dir::TempDir::new("results_wanted");
        let dir = tmp.path();
        let c = Capture::new(Some(dir));
        let table = |name: &str| {
            let p = dir.join(name);
            let mut w =
                crate::storage::StoWriter::create(&p, "t", "", &["a".to_string()], 8, false)
                    .unwrap();
            for k in 0..3 {
                w.write_row(k as f64, &[0.5]).unwrap();
            }
            w.finish().unwrap();
            p
        };
        // Two consumers read `read.sto`; nobody reads `unread.sto` or the report.
        let read = dir.join("read.sto");
        want(&read);
        want(&read);
        table("read.sto");
        let unread = table("unread.sto");
        write(&dir.join("report.txt"), b"not read".to_vec()).unwrap();
        let (n, bytes) = c.kept();
        assert_eq!(n, 1, "{:?}", c.outputs());
        // Three rows of a time and one value, as f64.
        assert_eq!(bytes, 3 * KeptTable::row_size(1) as u64);
        assert!(get(&unread).is_none());
        // Both files are whole on the disk.
        assert_eq!(crate::storage::read(&unread).unwrap().len(), 3);
        crate::storage::read(&read).unwrap();
        assert_eq!(crate::storage::times_opened(&read), 0);
        done(&read);
        assert_eq!(c.kept().0, 1, "dropped before its last consumer read it");
        done(&read);
        assert_eq!(c.kept(), (0, 0));
        assert!(get(&read).is_none());
    }

    #[test]
    fn a_kept_value_is_the_value_its_file_gives_back() {
        // The printed digits parsed (the reader's `str::parse`, bit for
        // bit) against the value computed: random values of every scale,
        // the halfway cases, zeros of both signs, large values.
        let printed = |x: f64, p: usize| -> f64 {
            crate::storage::format_c_fixed(x, 0, p)
                .trim()
                .parse()
                .unwrap()
        };
        let mut seed = 0x2545_f491_4f6c_dd1du64;
        let mut next = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            seed
        };
        let mut values = vec![0.0, -0.0, 1e-12, -1e-12, 0.5, -0.5, 2.5e-8, -2.5e-8];
        // Exact binary halfway cases at 8 decimals: odd multiples of 5^8 / 2^9.
        for k in [1.0, 3.0, 5.0, 7.0, 1001.0, -3.0] {
            values.push(k * 390625.0 / 512.0 * 1e-8);
            values.push(k * 390625.0 / 512.0);
        }
        for _ in 0..200_000 {
            let m = (next() >> 11) as f64 / (1u64 << 53) as f64 - 0.5;
            let e = (next() % 24) as i32 - 12;
            values.push(m * 10f64.powi(e));
        }
        values.extend([4.4e7, -4.6e7, 1e15, 1.0e300]);
        for &x in &values {
            for p in [0, 3, 8, 12, 16, 20, 25] {
                let (got, want) = (as_printed(x, p), printed(x, p));
                assert_eq!(
                    got.to_bits(),
                    want.to_bits(),
                    "{x:e} at {p} decimals: {got} != {want}"
                );
            }
        }
        assert!(as_printed(f64::NAN, 8).is_nan());
    }

    #[test]
    fn a_kept_table_reads_as_its_file_and_refuses_what_the_reader_refuses() {
        let tmp = crate::test_dir::TempDir::new("results_typed");
        let dir = tmp.path();
        let _c = Capture::new(Some(dir));
        let labels = ["a".to_string(), "b".to_string()];
        let write = |name: &str, rows: &[(f64, [f64; 2])]| {
            let p = dir.join(name);
            want(&p);
            let mut w = crate::storage::StoWriter::create_for_setup(
                Path::new("setup.xml"),
                &p,
                "t",
                "a description\nkey=value\n",
                &labels,
                8,
                false,
            )
            .unwrap();
            for (t, v) in rows {
                w.write_row(*t, v).unwrap();
            }
            w.finish().unwrap();
            p
        };
        let good = write(
            "good.sto",
            &[(0.0, [1.0 / 3.0, -1e-12]), (0.01, [2.0, 123.456789125])],
        );
        let file =
            crate::storage::read_file(&crate::storage::TableFile::read(&good).unwrap()).unwrap();
        let kept = crate::storage::read(&good).unwrap();
        assert_eq!(
            crate::storage::times_opened(&good),
            1,
            "the kept table was read from its file"
        );
        assert_eq!(format!("{kept:?}"), format!("{file:?}"));
        let mut rows = crate::storage::open_rows(&good).unwrap();
        assert_eq!(rows.table.labels, file.labels);
        let mut row = Vec::new();
        assert_eq!(rows.next_row(&mut row).unwrap(), Some(0.0));
        let mark = rows.mark();
        assert_eq!(rows.next_row(&mut row).unwrap(), Some(0.01));
        assert_eq!(row, file.rows[1]);
        assert_eq!(rows.next_row(&mut row).unwrap(), None);
        rows.seek(&mark).unwrap();
        assert_eq!(rows.next_row(&mut row).unwrap(), Some(0.01));
        // What the reader refuses in the file is refused the same way.
        for (name, rows) in [
            ("nan.sto", vec![(0.0, [1.0, 1.0]), (0.1, [1.0, f64::NAN])]),
            ("time.sto", vec![(0.0, [1.0, 1.0]), (0.0, [1.0, 1.0])]),
        ] {
            let p = write(name, &rows);
            let from_file =
                crate::storage::read_file(&crate::storage::TableFile::read(&p).unwrap())
                    .unwrap_err()
                    .to_string();
            let kept = crate::storage::read(&p).unwrap_err().to_string();
            assert_eq!(kept, from_file);
        }
    }

    #[test]
    fn two_runs_in_one_process_keep_apart_even_in_one_folder() {
        // Two runs on two threads, both capturing the same folder, at the
        // same time: each keeps its own outputs only and reads only its
        // own (a registry shared by the process would hand both to the
        // newer capture).
        let tmp = crate::test_dir::TempDir::new("results_two_runs");
        let dir = tmp.path().to_path_buf();
        let both = std::sync::Barrier::new(2);
        let run = |name: &str, value: f64| {
            let c = Capture::new(Some(&dir));
            both.wait(); // both captures exist
            let p = dir.join(name);
            want(&p);
            let mut w =
                crate::storage::StoWriter::create(&p, "t", "", &["a".to_string()], 8, false)
                    .unwrap();
            w.write_row(0.0, &[value]).unwrap();
            w.finish().unwrap();
            both.wait(); // both tables written
            let other = dir.join(if name == "a.sto" { "b.sto" } else { "a.sto" });
            let outputs: Vec<PathBuf> = c.outputs().into_iter().map(|(p, _)| p).collect();
            let mine = crate::storage::read(&p).unwrap().rows;
            (outputs, get(&other).is_some(), mine, key(&p))
        };
        let (a, b) = std::thread::scope(|s| {
            let a = s.spawn(|| run("a.sto", 1.0));
            let b = s.spawn(|| run("b.sto", 2.0));
            (a.join().unwrap(), b.join().unwrap())
        });
        for ((outputs, sees_other, rows, own), v) in [(a, 1.0), (b, 2.0)] {
            assert_eq!(outputs, vec![own], "a capture holds another run's output");
            assert!(!sees_other, "a run sees another run's output");
            assert_eq!(rows, vec![vec![v]]);
        }
        // Work handed to another thread with the run's context is the run's.
        let c = Capture::new(Some(&dir));
        let ctx = context();
        let p = dir.join("handed.sto");
        want(&p);
        std::thread::scope(|s| {
            s.spawn(|| {
                assert!(!captured(&p), "a thread without the run's context");
                let _run = ctx.enter();
                write(&p, b"x".to_vec()).unwrap();
            });
        });
        assert_eq!(c.outputs().len(), 1);
        assert!(get(&p).is_some());
    }
}
