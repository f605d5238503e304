//! AnalyzeTool's states (opensim-semantics.md §9.2, §6.3) computed window by
//! window, so that memory does not grow with the length of the trial.
//!
//! The in-memory path ([`crate::tools::loading::load_coordinates`],
//! [`States::from_coordinates`](crate::motion::states::States::from_coordinates),
//! [`States::speed_derivatives`](crate::motion::states::States::speed_derivatives))
//! holds every row several times over. The same chain is
//!
//! 1. P: the coordinates padded by half their length (`Storage::pad`,
//!    reflect-and-negate about the first and last rows);
//! 2. G: P resampled at its smallest step with quintic interpolating splines
//!    when P is not uniform (`Storage::resample`: grid t = t₀, t₀+dt, …
//!    by repeated floating-point addition, at most `MAX_RESAMPLE_SIZE`
//!    steps), else P itself;
//! 3. F: G through the third-order Butterworth filter forward and backward
//!    (`Signal::LowpassIIR`, first three outputs of each pass = inputs);
//! 4. q = F (degrees converted), u = S_q′ at the rows, assembled, then
//!    u̇ = S_u′ at the rows.
//!
//! Without a cut-off, steps 1–3 are skipped (G = the file's rows).
//!
//! Every step has exponentially decaying memory: a natural interpolating
//! quintic spline's value on a knot interval depends on data k knots away
//! with weight ≈ 0.43ᵏ, and the filter's output on an input (or initial
//! condition) k samples away with weight ≲ rᵏ, r the largest pole radius.
//! So a value computed on a window that extends [`SPLINE_OVERLAP`] knots
//! (splines) or ⌈ln 10⁻¹⁸ / ln r⌉ samples (filter) past it on each side equals
//! the global value to rounding. Windows are clipped only at the true ends
//! of each sequence, where the true end conditions (natural spline ends,
//! the filter's initial conditions, the padding) then apply exactly. A
//! motion that fits in one window is computed exactly as the in-memory path
//! computes it, bit for bit.
//!
//! The file is read row by row ([`crate::storage::open_rows`]): once for its
//! length, end rows and a file position every few thousand rows, once for
//! P's smallest step, once to locate the analysed time range in P, and then
//! to stream the values — the data rows in order, the reflected padding (rows
//! in reverse order) a chunk at a time from the recorded positions. A file of
//! at most a block of rows is read once: the first read keeps its rows and
//! the other passes take them from memory. Memory is O(block + overlaps +
//! chunk) rows, whatever the length of the file and whichever part of it
//! (padding included) is analysed.
//!
//! A run hands the stream its motion as a [`TableFile`]
//! ([`StateStream::open_in`]): the file's bytes, read once by the run's
//! driver, which every pass above parses with the same row reader
//! ([`crate::storage::open_rows_in`]); then memory grows by the file's size
//! (at most [`crate::storage::IN_MEMORY_LIMIT`]). A larger file, or a
//! stream opened on a path ([`StateStream::open`]), reads each pass from
//! the disk, and memory stays O(block + overlaps + chunk) rows.
//!
//! The InverseDynamicsTool's states ([`StatesKind::InverseDynamics`]) come
//! from the same windows: q = S, u = S′, u̇ = S″ of each coordinate's spline
//! at the rows, no assembly.
//!
//! u and u̇ at the rows are the splines' slopes at their knots
//! ([`SplineFitter::knot_slopes_columns`]: one spline system per window,
//! shared by the columns, the bits of `GcvSpline::derivative(t_i, 1)`).

use std::collections::VecDeque;
use std::path::{Path, PathBuf};

use crate::error::{Error, Location, Result};
use crate::functions::SplineFitter;
use crate::model::{Model, MotionType};
use crate::motion::coordinates::{column_for, units_error};
use crate::motion::filter::{butterworth, iir_pass, pole_radius, MAX_RESAMPLE_SIZE};
use crate::motion::states::assemble;
use crate::storage::{open_rows_in, RowMark, RowReader, TableFile};

/// Knots of overlap on each side of a spline window: 0.43¹⁰⁰ ≈ 10⁻³⁷.
pub const SPLINE_OVERLAP: usize = 100;

/// Default rows per block.
pub const DEFAULT_BLOCK: usize = 4096;

/// A run of consecutive rows of the states table.
#[derive(Debug, Clone, Default)]
pub struct StateBlock {
    /// Row index (in the padded, resampled table) of the first row.
    pub first: usize,
    pub time: Vec<f64>,
    /// `q[row][coordinate]`, tree order, assembled.
    pub q: Vec<Vec<f64>>,
    pub u: Vec<Vec<f64>>,
    /// Target accelerations u̇ = S_u′ (§6.3).
    pub udot: Vec<Vec<f64>>,
}

/// Blocks of consecutive frames, in order: what the frame driver
/// (`frame::driver::for_each_frame`) runs over. The AnalyzeTool's states
/// ([`StateStream`]) and the InverseDynamicsTool's spline derivatives
/// (`motion::coordinates::SplineFrames`) are two sources.
pub trait FrameSource {
    /// The next block; None after the last row.
    fn next_block(&mut self) -> Result<Option<StateBlock>>;
}

impl FrameSource for StateStream<'_> {
    fn next_block(&mut self) -> Result<Option<StateBlock>> {
        StateStream::next_block(self)
    }
}

/// A change made to every row of the (filtered) coordinates table before it
/// is splined, e.g. `<close_contacts>` solving a coordinate so that a contact
/// closes (`contacts::closure::StreamClosure`; it lives in a later stage,
/// hence the trait). Rows come window by window, in order within a window;
/// a window starts at or after the previous one's start, so rows near a
/// window's start are given again (see [`StateStream::with_row_transform`]).
pub trait RowTransform: Send {
    /// A window of rows from `first` on begins.
    fn begin_window(&mut self, first: usize);
    /// Change row `row` (time `t`): the carried columns in the file's units,
    /// in [`StateStream::carried_columns`]' order.
    fn apply(&mut self, row: usize, t: f64, values: &mut [f64]) -> Result<()>;
}

/// How a [`StateStream`]'s states follow from the coordinates' splines.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StatesKind {
    /// AnalyzeTool (opensim-semantics.md §9.2): q the (filtered) rows,
    /// assembled; u = S_q′ at the knots; u̇ = S_u′ at the knots; coordinates
    /// the file lacks at 0.
    Analyze,
    /// InverseDynamicsTool: q = S_q, u = S_q′, u̇ = S_q″ at the rows (one
    /// quintic spline per coordinate, differentiated), not assembled;
    /// coordinates the file lacks at their default values, u = u̇ = 0.
    InverseDynamics,
}

/// Rows of the states table, in order, for the rows `first_row..=last_row`.
pub struct StateStream<'m> {
    model: &'m Model,
    file: PathBuf,
    /// Per coordinate: (index into the carried columns, degrees→radians scale).
    coord_cols: Vec<Option<(usize, f64)>>,
    labels: Vec<String>,
    /// Coordinates the table lacks (set to 0, as AnalyzeTool does).
    pub missing: Vec<String>,
    /// What [`super::checks::time_warnings`] says about the file, and the
    /// requested time range (see [`Self::motion_warnings`]).
    pub warnings: Vec<String>,
    /// The file's columns that name no coordinate of the model.
    pub unmatched_columns: Vec<String>,
    /// Rows of the whole states table and its first and last times.
    pub rows: usize,
    pub first_time: f64,
    pub last_time: f64,
    /// The first and last times of the file itself (before any padding).
    pub file_times: (f64, f64),
    /// OpenSim's `findIndex` of the initial and final times in the table.
    pub first_row: usize,
    pub last_row: usize,
    filter: Option<([f64; 4], [f64; 4])>,
    /// Filter overlap (0 without a filter).
    k: usize,
    g: GSource,
    /// Rows `gbuf_start..` of G (time, carried columns in file units).
    gbuf: VecDeque<(f64, Vec<f64>)>,
    gbuf_start: usize,
    g_end: usize,
    next_out: usize,
    block: usize,
    /// Rows computed in memory, handed out as one block ([`Self::in_memory`]).
    memory: Option<StateBlock>,
    /// Columns added for coordinates the file lacks and a row transform
    /// sets (their value before it: the default value, in file units).
    synthetic: Vec<f64>,
    transform: Option<Box<dyn RowTransform + 'm>>,
    /// The file's `inDegrees`.
    in_degrees: bool,
    /// Degree of the interpolating splines for u and u̇ (5: OpenSim's).
    degree: usize,
    kind: StatesKind,
    /// What the file's dependent-coordinate columns say against their
    /// couplers (AnalyzeTool; [`Self::motion_warnings`]).
    dependent_warnings: Vec<String>,
}

impl<'m> StateStream<'m> {
    /// Everything to say about the motion file: its time column, the time
    /// range asked for, and columns that match no coordinate (but for
    /// `known`, e.g. coordinates a model reduction removed).
    pub fn motion_warnings(&self, known: &[String]) -> Vec<String> {
        let unmatched: Vec<String> = self
            .unmatched_columns
            .iter()
            .filter(|c| !known.contains(c))
            .cloned()
            .collect();
        let mut out = self.warnings.clone();
        if self.kind == StatesKind::Analyze {
            // The InverseDynamicsTool splines the file's values of
            // dependent coordinates as they are: nothing to say.
            out.extend(self.dependent_warnings.iter().cloned());
        }
        out.extend(super::checks::unmatched_columns_warning(
            &self.file, &unmatched,
        ));
        out
    }

    /// Open the coordinates `file` for the model; `cutoff` < 0 means no
    /// filtering; rows from `findIndex(initial)` to `findIndex(final)` are
    /// produced.
    pub fn open(
        model: &'m Model,
        file: &Path,
        cutoff: f64,
        initial: f64,
        final_: f64,
    ) -> Result<StateStream<'m>> {
        Self::open_with_block(model, file, cutoff, initial, final_, DEFAULT_BLOCK)
    }

    /// As [`open`](Self::open) with `block` rows per block (tests use small
    /// blocks to exercise the windows on short motions).
    pub fn open_with_block(
        model: &'m Model,
        file: &Path,
        cutoff: f64,
        initial: f64,
        final_: f64,
        block: usize,
    ) -> Result<StateStream<'m>> {
        Self::open_in_with_block(
            model,
            &TableFile::on_disk(file),
            cutoff,
            initial,
            final_,
            block,
        )
    }

    /// As [`open`](Self::open) on a [`TableFile`]: every pass reads the
    /// bytes it holds (a run's motion, read once), or the file on disk.
    pub fn open_in(
        model: &'m Model,
        source: &TableFile,
        cutoff: f64,
        initial: f64,
        final_: f64,
    ) -> Result<StateStream<'m>> {
        Self::open_in_with_block(model, source, cutoff, initial, final_, DEFAULT_BLOCK)
    }

    /// As [`open_in`](Self::open_in) with `block` rows per block.
    pub fn open_in_with_block(
        model: &'m Model,
        source: &TableFile,
        cutoff: f64,
        initial: f64,
        final_: f64,
        block: usize,
    ) -> Result<StateStream<'m>> {
        let file = source.path();
        let block = block.max(1);
        let reader = open_rows_in(source)?;
        // Columns the model needs, in the order first needed.
        let mut sel: Vec<usize> = Vec::new();
        let mut coord_cols = Vec::with_capacity(model.nq());
        let mut missing = Vec::new();
        for c in &model.coordinates {
            match column_for(&reader.table, &c.name) {
                Some(j) => {
                    let scale =
                        if reader.table.in_degrees && c.motion_type == MotionType::Rotational {
                            std::f64::consts::PI / 180.0
                        } else {
                            1.0
                        };
                    let pos = sel.iter().position(|&s| s == j).unwrap_or_else(|| {
                        sel.push(j);
                        sel.len() - 1
                    });
                    coord_cols.push(Some((pos, scale)));
                }
                None => {
                    missing.push(c.name.clone());
                    coord_cols.push(None);
                }
            }
        }
        let labels: Vec<String> = sel
            .iter()
            .map(|&j| reader.table.labels[j].clone())
            .collect();
        let all_labels = reader.table.labels.clone();
        let mut steps = super::checks::TimeSteps::default();
        let filtering = cutoff >= 0.0;
        let ctx = |e: Error| e.context(format!("filtering {}", file.display()));

        // Pass 1: length and end times.
        let in_degrees = reader.table.in_degrees;
        let mut dependent = super::checks::DependentMismatch::new(model);
        let mut check = |k: usize, t: f64, picked: &[f64]| -> Result<()> {
            steps.push(t);
            dependent.push(model, t, |c| {
                coord_cols[c].map(|(pos, scale)| picked[pos] * scale)
            });
            // wrong units: values far outside a coordinate's range (not for
            // dependent coordinates: their couplers set them)
            for (c, cc) in model.coordinates.iter().zip(&coord_cols) {
                if c.dependent {
                    continue;
                }
                if let Some((pos, scale)) = *cc {
                    let label = &labels[pos];
                    let x = picked[pos] * scale;
                    if let Some(e) = units_error(c, label, in_degrees, k, t, x, file) {
                        return Err(e);
                    }
                }
            }
            Ok(())
        };
        let index = index_file(reader, &sel, &mut check, block)?;
        let warnings = super::checks::time_warnings(file, &steps, cutoff)?;
        let dependent_warnings = dependent.warnings(model, file);
        let unmatched_columns = super::checks::unmatched_columns(model, &all_labels);
        let (n, t0, tl) = (index.n, index.first.0, index.last.0);
        let p = if filtering && n >= 1 { n / 2 } else { 0 };
        let m = n + 2 * p;
        let p_time = |k: usize, t: f64, f: &mut dyn FnMut(f64)| {
            // every image of raw row k in P
            f(t);
            if p > 0 && (1..=p).contains(&k) {
                f(2.0 * t0 - t);
            }
            if p > 0 && k + 1 + p >= n && k + 2 <= n {
                f(2.0 * tl - t);
            }
        };
        let (p_first, p_last) = if p > 0 {
            // rows p and n-1-p, read in pass 2
            (f64::NAN, f64::NAN)
        } else {
            (t0, tl)
        };

        // Pass 2 (filtering): P's smallest step and end times.
        let mut resample = None;
        let (mut p_first, mut p_last) = (p_first, p_last);
        let mut dt_filter = 0.0;
        if filtering && n >= 2 {
            let mut min_step = f64::INFINITY;
            let mut prev = 0.0;
            for_each_time(source, &index, &mut |k, t| {
                if k >= 1 {
                    min_step = min_step.min(t - prev);
                    if p > 0 && k >= 2 && k <= p {
                        min_step = min_step.min((2.0 * t0 - prev) - (2.0 * t0 - t));
                    }
                    if p > 0 && k >= 2 && k - 1 + 1 + p >= n && k + 2 <= n {
                        min_step = min_step.min((2.0 * tl - prev) - (2.0 * tl - t));
                    }
                }
                if p > 0 && k == 1 {
                    min_step = min_step.min(t0 - (2.0 * t0 - t));
                }
                if p > 0 && k + 2 == n {
                    min_step = min_step.min((2.0 * tl - t) - tl);
                }
                if p > 0 && k == p {
                    p_first = 2.0 * t0 - t;
                }
                if p > 0 && k + 1 + p == n {
                    p_last = 2.0 * tl - t;
                }
                prev = t;
            })?;
            let mut dt = min_step;
            if dt < f64::EPSILON {
                return Err(ctx(Error::msg(format!("the time column has a step of {dt}: rows must have strictly increasing times to be filtered"))));
            }
            let avg = (p_last - p_first) / (m - 1) as f64;
            if avg - dt > f64::EPSILON {
                if (p_last - p_first) / dt > MAX_RESAMPLE_SIZE {
                    dt = (p_last - p_first) / MAX_RESAMPLE_SIZE;
                }
                resample = Some((dt, min_step));
            }
            dt_filter = dt;
        }

        // The table's rows: the resampling grid, or P itself.
        let (rows, first_time, last_time, first_row, last_row, grid_lo_hi);
        if let Some((dt, _)) = resample {
            let (mut count, mut c_init, mut c_final) = (0usize, 0usize, 0usize);
            let mut x = p_first;
            let mut last = p_first;
            while x <= p_last {
                count += 1;
                c_init += (x <= initial) as usize;
                c_final += (x <= final_) as usize;
                last = x;
                x += dt;
            }
            rows = count;
            first_time = p_first;
            last_time = last;
            first_row = c_init.saturating_sub(1);
            last_row = c_final.saturating_sub(1);
            grid_lo_hi = true;
        } else {
            let (mut c_init, mut c_final) = (0usize, 0usize);
            if n > 0 {
                for_each_time(source, &index, &mut |k, t| {
                    p_time(k, t, &mut |pt| {
                        c_init += (pt <= initial) as usize;
                        c_final += (pt <= final_) as usize;
                    });
                })?;
            }
            rows = m;
            first_time = p_first;
            last_time = p_last;
            first_row = c_init.saturating_sub(1);
            last_row = c_final.saturating_sub(1);
            grid_lo_hi = false;
        }
        if rows < 6 {
            return Err(Error::input(
                Location::file(file),
                format!(
                    "the motion has {rows} rows; at least 6 are needed for OpenSim's quintic splines"
                ),
            ));
        }
        let (filter, k) = if filtering && rows >= 4 && dt_filter != 0.0 {
            let (a, b) = butterworth(dt_filter, cutoff);
            let r = pole_radius(&b);
            let k = if r < 1.0 && r > 0.0 {
                ((1e-18f64).ln() / r.ln()).ceil() as usize + 16
            } else if r == 0.0 {
                16
            } else {
                rows
            };
            (Some((a, b)), k)
        } else {
            (None, 0)
        };
        let margin = 2 * SPLINE_OVERLAP + k + 2;
        let gs = first_row.saturating_sub(margin);
        let ge = (last_row + 1 + margin).min(rows);
        let (js, je, g) = if grid_lo_hi {
            let (dt, min_step) = resample.unwrap_or((0.0, 0.0));
            // grid times at gs and ge-1, by the same repeated addition
            let mut x = p_first;
            let (mut t_lo, mut t_hi) = (p_first, p_first);
            let mut i = 0usize;
            while x <= p_last && i < ge {
                if i == gs {
                    t_lo = x;
                }
                t_hi = x;
                x += dt;
                i += 1;
            }
            let (mut below, mut upto) = (0usize, 0usize);
            for_each_time(source, &index, &mut |kk, t| {
                p_time(kk, t, &mut |pt| {
                    below += (pt < t_lo) as usize;
                    upto += (pt <= t_hi) as usize;
                });
            })?;
            let js = below.saturating_sub(SPLINE_OVERLAP + 2);
            let je = (upto + SPLINE_OVERLAP + 2).min(m);
            let src = PSource::new(source, sel.clone(), index, p, js, je);
            let g = GSource::Resampled {
                p: src,
                knots: VecDeque::new(),
                dt,
                x: p_first,
                p_last,
                index: 0,
                start: gs,
                end: ge,
                labels: labels.clone(),
                pending: VecDeque::new(),
                // grid rows per spline window: about `block` knots even
                // when the step is capped (several knots per grid step)
                block: ((block as f64 * min_step / dt) as usize).clamp(16, block.max(16)),
            };
            (js, je, g)
        } else {
            let src = PSource::new(source, sel.clone(), index, p, gs, ge);
            (gs, ge, GSource::Direct(src))
        };
        let _ = (js, je);
        Ok(StateStream {
            model,
            file: file.to_path_buf(),
            coord_cols,
            labels,
            missing,
            warnings,
            unmatched_columns,
            rows,
            first_time,
            last_time,
            file_times: (t0, tl),
            first_row,
            last_row,
            filter,
            k,
            g,
            gbuf: VecDeque::new(),
            gbuf_start: gs,
            g_end: ge,
            next_out: first_row,
            block,
            memory: None,
            synthetic: Vec::new(),
            transform: None,
            in_degrees,
            degree: 5,
            kind: StatesKind::Analyze,
            dependent_warnings,
        })
    }

    /// States computed in memory (`States::from_coordinates`,
    /// `States::speed_derivatives`) behind the same interface: the rows
    /// `findIndex(initial)..=findIndex(final)` as one block.
    pub fn in_memory(
        model: &'m Model,
        states: crate::motion::states::States,
        udot: Vec<Vec<f64>>,
        initial: f64,
        final_: f64,
    ) -> StateStream<'m> {
        use crate::motion::coordinates::find_index;
        let rows = states.time.len();
        let first_row = find_index(&states.time, initial);
        let last_row = find_index(&states.time, final_);
        let (first_time, last_time) = (
            states.time.first().copied().unwrap_or(0.0),
            states.time.last().copied().unwrap_or(0.0),
        );
        let memory = (rows > 0 && last_row >= first_row).then(|| {
            let r = first_row..last_row + 1;
            StateBlock {
                first: first_row,
                time: states.time[r.clone()].to_vec(),
                q: states.q[r.clone()].to_vec(),
                u: states.u[r.clone()].to_vec(),
                udot: udot[r].to_vec(),
            }
        });
        StateStream {
            model,
            file: PathBuf::new(),
            coord_cols: Vec::new(),
            labels: Vec::new(),
            missing: states.missing,
            warnings: Vec::new(),
            unmatched_columns: Vec::new(),
            rows,
            first_time,
            last_time,
            file_times: (first_time, last_time),
            first_row,
            last_row,
            filter: None,
            k: 0,
            g: GSource::Empty,
            gbuf: VecDeque::new(),
            gbuf_start: 0,
            g_end: 0,
            next_out: first_row,
            block: rows.max(1),
            memory,
            synthetic: Vec::new(),
            transform: None,
            in_degrees: false,
            degree: 5,
            kind: StatesKind::Analyze,
            dependent_warnings: Vec::new(),
        }
    }

    /// Spline the coordinates and speeds with interpolating splines of
    /// `degree` instead of OpenSim's quintic (statopt's `<coordinate_spline>`;
    /// the resampling of a non-uniform motion stays quintic).
    pub fn with_spline_degree(mut self, degree: usize) -> Self {
        self.degree = degree;
        self
    }

    /// The InverseDynamicsTool's states instead of the AnalyzeTool's
    /// ([`StatesKind::InverseDynamics`]).
    pub fn for_inverse_dynamics(mut self) -> Self {
        self.kind = StatesKind::InverseDynamics;
        self
    }

    /// Which states this stream hands out.
    pub fn kind(&self) -> StatesKind {
        self.kind
    }

    /// Per model coordinate, its carried column (index into a row's values)
    /// and the factor from the file's units to the model's.
    pub fn carried_columns(&self) -> &[Option<(usize, f64)>] {
        &self.coord_cols
    }

    /// Whether a row transform changes the rows ([`Self::with_row_transform`]).
    pub fn transforms_rows(&self) -> bool {
        self.transform.is_some()
    }

    /// Apply `transform` to every row of the table, from its first row (the
    /// stream then hands out the rows before `first_row` too; frames are
    /// chosen by row index), after the filter and before the splines, as
    /// the in-memory path changes its table. `added` are coordinates the file
    /// lacks and the transform sets: each gets a carried column holding its
    /// default value (in the file's units) before the transform runs, and is
    /// no longer missing; `transform` is made from the carried columns with
    /// those added. Err (the stream unchanged) when the motion is
    /// resampled (a non-uniform time column, filtered): the caller then
    /// computes the states in memory. Call before the first block.
    pub fn with_row_transform(
        mut self,
        added: &[usize],
        transform: impl FnOnce(&[Option<(usize, f64)>]) -> Box<dyn RowTransform + 'm>,
    ) -> std::result::Result<Self, Box<Self>> {
        let GSource::Direct(src) = &mut self.g else {
            return Err(Box::new(self));
        };
        if !self.gbuf.is_empty() || self.next_out != self.first_row {
            return Err(Box::new(self));
        }
        src.j = 0;
        self.gbuf_start = 0;
        self.next_out = 0;
        for &c in added {
            if self.coord_cols[c].is_some() {
                continue;
            }
            let coordinate = &self.model.coordinates[c];
            let scale = if self.in_degrees && coordinate.motion_type == MotionType::Rotational {
                std::f64::consts::PI / 180.0
            } else {
                1.0
            };
            self.coord_cols[c] = Some((self.labels.len(), scale));
            self.labels.push(coordinate.name.clone());
            self.synthetic.push(coordinate.default_value / scale);
            self.missing.retain(|m| *m != coordinate.name);
        }
        self.transform = Some(transform(&self.coord_cols));
        Ok(self)
    }

    /// The next block of rows, in order; None after `last_row`.
    pub fn next_block(&mut self) -> Result<Option<StateBlock>> {
        if let GSource::Empty = self.g {
            self.next_out = self.last_row + 1;
            return Ok(self.memory.take());
        }
        if self.next_out > self.last_row || self.next_out >= self.rows {
            return Ok(None);
        }
        let s = SPLINE_OVERLAP;
        let a = self.next_out;
        let b = (a + self.block).min(self.last_row + 1);
        let lo = a.saturating_sub(2 * s + self.k).max(self.gbuf_start);
        let hi = (b + 2 * s + self.k).min(self.g_end);
        while self.gbuf_start + self.gbuf.len() < hi {
            match self.g.next()? {
                Some(r) => self.gbuf.push_back(r),
                None => {
                    return Err(Error::msg(format!(
                        "{}: internal error: the state stream ended early at row {}",
                        self.file.display(),
                        self.gbuf_start + self.gbuf.len()
                    )))
                }
            }
        }
        while self.gbuf_start < lo {
            self.gbuf.pop_front();
            self.gbuf_start += 1;
        }
        let w0 = self.gbuf_start;
        let w1 = hi;
        let len = w1 - w0;
        let time: Vec<f64> = self.gbuf.iter().take(len).map(|r| r.0).collect();
        // F on the window, per carried column.
        let ncol = self.labels.len() - self.synthetic.len();
        let mut cols: Vec<Vec<f64>> = (0..ncol)
            .map(|j| self.gbuf.iter().take(len).map(|r| r.1[j]).collect())
            .collect();
        if let Some((fa, fb)) = &self.filter {
            for col in cols.iter_mut() {
                let mut fwd = iir_pass(fa, fb, col);
                fwd.reverse();
                let mut back = iir_pass(fa, fb, &fwd);
                back.reverse();
                *col = back;
            }
        }
        cols.extend(self.synthetic.iter().map(|&v| vec![v; len]));
        if let Some(tr) = self.transform.as_mut() {
            tr.begin_window(w0);
            let mut row = vec![0.0; cols.len()];
            for i in 0..len {
                for (x, col) in row.iter_mut().zip(&cols) {
                    *x = col[i];
                }
                tr.apply(w0 + i, time[i], &mut row)?;
                for (x, col) in row.iter().zip(cols.iter_mut()) {
                    col[i] = *x;
                }
            }
        }
        // q and u on [ua, ub), u̇ on [a, b) (indices relative to w0).
        let (qa, qb) = (
            a.saturating_sub(2 * s).max(w0) - w0,
            (b + 2 * s).min(w1) - w0,
        );
        if self.kind == StatesKind::InverseDynamics {
            let block = self.inverse_dynamics_block(a, b, w0, &time, &cols, (qa, qb))?;
            self.next_out = b;
            return Ok(Some(block));
        }
        let (ua, ub) = (a.saturating_sub(s).max(w0) - w0, (b + s).min(w1) - w0);
        let nq = self.model.nq();
        let nu = ub - ua;
        let mut q = vec![vec![0.0; nq]; nu];
        let mut u = vec![vec![0.0; nq]; nu];
        // u = S_q′ and u̇ = S_u′ at the knots: one spline system per set of
        // abscissae, shared by the columns (the same bits as splining each).
        let mut fit_q = SplineFitter::new(self.degree, &time[qa..qb]);
        let mut slopes = Vec::new();
        let (picked, vs) = self.model_columns(&cols, qa..qb);
        let ys: Vec<&[f64]> = vs.iter().map(|v| v.as_slice()).collect();
        fit_q
            .knot_slopes_columns(&ys, &mut slopes)
            .map_err(|(i, e)| self.column_error(picked[i].1, e))?;
        for ((&(c, _, _), v), sl) in picked.iter().zip(&vs).zip(&slopes) {
            for i in 0..nu {
                q[i][c] = v[ua + i - qa];
                u[i][c] = sl[ua + i - qa];
            }
        }
        for i in 0..nu {
            assemble(self.model, time[ua + i], &mut q[i], &mut u[i]);
        }
        let (oa, ob) = (a - w0 - ua, b - w0 - ua);
        let mut udot = vec![vec![0.0; nq]; b - a];
        let mut fit_u = if (ua, ub) == (qa, qb) {
            fit_q
        } else {
            SplineFitter::new(self.degree, &time[ua..ub])
        };
        let us: Vec<Vec<f64>> = (0..nq).map(|c| u.iter().map(|r| r[c]).collect()).collect();
        let ys: Vec<&[f64]> = us.iter().map(|v| v.as_slice()).collect();
        fit_u
            .knot_slopes_columns(&ys, &mut slopes)
            .map_err(|(_, e)| {
                Error::input(Location::file(&self.file), format!("splining speeds: {e}"))
            })?;
        for (c, sl) in slopes.iter().enumerate() {
            for i in oa..ob {
                udot[i - oa][c] = sl[i];
            }
        }
        self.next_out = b;
        // The block's rows, moved out of the window's (no copies).
        q.truncate(ob);
        q.drain(..oa);
        u.truncate(ob);
        u.drain(..oa);
        Ok(Some(StateBlock {
            first: a,
            time: time[a - w0..b - w0].to_vec(),
            q,
            u,
            udot,
        }))
    }
}

impl StateStream<'_> {
    /// The coordinates the file has, as (coordinate, carried column,
    /// factor to model units), and their values in model units on the
    /// window's rows `rows` of the (filtered) columns `cols`.
    #[allow(clippy::type_complexity)]
    fn model_columns(
        &self,
        cols: &[Vec<f64>],
        rows: std::ops::Range<usize>,
    ) -> (Vec<(usize, usize, f64)>, Vec<Vec<f64>>) {
        let picked: Vec<(usize, usize, f64)> = (self.coord_cols.iter().enumerate())
            .filter_map(|(c, cc)| cc.map(|(j, scale)| (c, j, scale)))
            .collect();
        let vs = picked
            .iter()
            .map(|&(_, j, scale)| cols[j][rows.clone()].iter().map(|x| x * scale).collect())
            .collect();
        (picked, vs)
    }

    /// `e`, said of the file's carried column `j`.
    fn column_error(&self, j: usize, e: Error) -> Error {
        e.context(format!(
            "{}: column '{}'",
            self.file.display(),
            self.labels[j]
        ))
    }

    /// Rows `a..b` of the InverseDynamicsTool's states from the window
    /// starting at row `w0` (`time`, the filtered `cols` in file units):
    /// each coordinate's spline through the window's rows `qa..qb`, and its
    /// value and first two derivatives at the rows (`GcvSpline::value`,
    /// `derivative`: a motion in one window gives the bits of one spline
    /// through all of it).
    fn inverse_dynamics_block(
        &self,
        a: usize,
        b: usize,
        w0: usize,
        time: &[f64],
        cols: &[Vec<f64>],
        (qa, qb): (usize, usize),
    ) -> Result<StateBlock> {
        let nq = self.model.nq();
        let n = b - a;
        let mut q = vec![vec![0.0; nq]; n];
        let mut u = q.clone();
        let mut udot = q.clone();
        for (c, cc) in self.coord_cols.iter().enumerate() {
            if cc.is_none() {
                let v = self.model.coordinates[c].default_value;
                q.iter_mut().for_each(|r| r[c] = v);
            }
        }
        let (picked, vs) = self.model_columns(cols, qa..qb);
        let ys: Vec<&[f64]> = vs.iter().map(|v| v.as_slice()).collect();
        let splines = SplineFitter::new(self.degree, &time[qa..qb])
            .splines(&ys)
            .map_err(|(i, e)| self.column_error(picked[i].1, e))?;
        let times = &time[a - w0..b - w0];
        for (&(c, _, _), sp) in picked.iter().zip(&splines) {
            for (i, &t) in times.iter().enumerate() {
                q[i][c] = sp.value(t);
                u[i][c] = sp.derivative(t, 1);
                udot[i][c] = sp.derivative(t, 2);
            }
        }
        Ok(StateBlock {
            first: a,
            time: times.to_vec(),
            q,
            u,
            udot,
        })
    }
}

/// Raw rows per chunk of the reflected padding, and between recorded file
/// positions.
const CHUNK: usize = if cfg!(test) { 97 } else { 4096 };

/// What the first read of the file records: its length, first and last rows
/// (carried columns) and a file position every [`CHUNK`] rows; and, when the
/// file has no more rows than a block, all of them (the later passes then
/// read them from memory instead of the file).
struct RawIndex {
    n: usize,
    first: (f64, Vec<f64>),
    last: (f64, Vec<f64>),
    marks: Vec<(usize, RowMark)>,
    rows: Option<Vec<(f64, Vec<f64>)>>,
}

/// Read the rows of `r` (opened, before its first row); keep them if there
/// are at most `keep` of them.
fn index_file(
    mut r: RowReader,
    sel: &[usize],
    check: &mut dyn FnMut(usize, f64, &[f64]) -> Result<()>,
    keep: usize,
) -> Result<RawIndex> {
    let mut row = Vec::new();
    let mut idx = RawIndex {
        n: 0,
        first: (0.0, Vec::new()),
        last: (0.0, Vec::new()),
        marks: Vec::new(),
        rows: Some(Vec::new()),
    };
    loop {
        if idx.n % CHUNK == 0 {
            idx.marks.push((idx.n, r.mark()));
        }
        let Some(t) = r.next_row(&mut row)? else {
            break;
        };
        // The last row's values, in a buffer reused from row to row; a
        // kept row gets a copy of its own.
        idx.last.0 = t;
        idx.last.1.clear();
        idx.last.1.extend(sel.iter().map(|&j| row[j]));
        let picked = &idx.last.1;
        check(idx.n, t, picked)?;
        if idx.n == 0 {
            idx.first = (t, picked.clone());
        }
        if let Some(rows) = &mut idx.rows {
            if rows.len() < keep {
                rows.push((t, picked.clone()));
            } else {
                idx.rows = None;
            }
        }
        idx.n += 1;
    }
    if idx.n == 0 {
        idx.last = (0.0, Vec::new());
    }
    Ok(idx)
}

/// `f(k, time of raw row k)` for every row, in order: from the rows
/// [`index_file`] kept, else read from the file again.
fn for_each_time(file: &TableFile, idx: &RawIndex, f: &mut dyn FnMut(usize, f64)) -> Result<()> {
    if let Some(rows) = &idx.rows {
        for (k, r) in rows.iter().enumerate() {
            f(k, r.0);
        }
        return Ok(());
    }
    let mut r = open_rows_in(file)?;
    let mut row = Vec::new();
    let mut k = 0;
    while let Some(t) = r.next_row(&mut row)? {
        f(k, t);
        k += 1;
    }
    Ok(())
}

/// P's rows `js..je` in order (time, carried columns), read from the file:
/// the data rows sequentially, the reflected padding a chunk of rows at a
/// time from recorded file positions (so neither is held whole).
struct PSource {
    sel: Vec<usize>,
    idx: RawIndex,
    p: usize,
    j: usize,
    je: usize,
    /// Reader for the data rows, in order.
    seq: Option<RowReader>,
    /// Reader for the chunks of the padding, and the chunk loaded: raw rows
    /// `chunk_lo..chunk_lo + chunk.len()`.
    rand: Option<RowReader>,
    chunk: Vec<(f64, Vec<f64>)>,
    chunk_lo: usize,
    file: TableFile,
    buf: Vec<f64>,
}

impl PSource {
    fn new(
        file: &TableFile,
        sel: Vec<usize>,
        idx: RawIndex,
        p: usize,
        js: usize,
        je: usize,
    ) -> PSource {
        PSource {
            sel,
            idx,
            p,
            j: js,
            je,
            seq: None,
            rand: None,
            chunk: Vec::new(),
            chunk_lo: 0,
            file: file.clone(),
            buf: Vec::new(),
        }
    }

    fn read_one(
        r: &mut RowReader,
        sel: &[usize],
        buf: &mut Vec<f64>,
        file: &Path,
    ) -> Result<(f64, Vec<f64>)> {
        let Some(t) = r.next_row(buf)? else {
            return Err(Error::msg(format!(
                "{}: the file changed while it was read",
                file.display()
            )));
        };
        Ok((t, sel.iter().map(|&j| buf[j]).collect()))
    }

    /// Raw row `k` (for the padding), through the chunk cache.
    fn raw(&mut self, k: usize, descending: bool) -> Result<&(f64, Vec<f64>)> {
        if let Some(rows) = &self.idx.rows {
            return Ok(&rows[k]);
        }
        if k < self.chunk_lo || k >= self.chunk_lo + self.chunk.len() {
            // the padding walks the rows downwards: load the chunk ending at k
            let lo = if descending {
                (k + 1).saturating_sub(CHUNK)
            } else {
                k
            };
            let hi = if descending {
                k + 1
            } else {
                (k + CHUNK).min(self.idx.n)
            };
            if self.rand.is_none() {
                self.rand = Some(open_rows_in(&self.file)?);
            }
            let r = self.rand.as_mut().expect("opened above");
            r.seek_row(lo, &self.idx.marks)?;
            self.chunk.clear();
            for _ in lo..hi {
                let row = Self::read_one(r, &self.sel, &mut self.buf, self.file.path())?;
                self.chunk.push(row);
            }
            self.chunk_lo = lo;
        }
        Ok(&self.chunk[k - self.chunk_lo])
    }

    fn next(&mut self) -> Result<Option<(f64, Vec<f64>)>> {
        if self.j >= self.je {
            return Ok(None);
        }
        let (p, n, j) = (self.p, self.idx.n, self.j);
        let out = if j < p {
            // Signal::Pad: 2·s[0] − s[pad − j]
            let k = p - j;
            let s0 = self.idx.first.clone();
            let sk = self.raw(k, true)?;
            let v = s0.1.iter().zip(&sk.1).map(|(a, b)| 2.0 * a - b).collect();
            (2.0 * s0.0 - sk.0, v)
        } else if j < p + n {
            let k = j - p;
            if let Some(rows) = &self.idx.rows {
                self.j += 1;
                return Ok(Some(rows[k].clone()));
            }
            if self.seq.is_none() {
                let mut r = open_rows_in(&self.file)?;
                r.seek_row(k, &self.idx.marks)?;
                self.seq = Some(r);
            }
            let r = self.seq.as_mut().expect("opened above");
            let row = Self::read_one(r, &self.sel, &mut self.buf, self.file.path())?;
            if k + 1 == n {
                self.seq = None;
            }
            row
        } else {
            // 2·s[n−1] − s[n − 2 − i]
            let k = n - 2 - (j - p - n);
            let sl = self.idx.last.clone();
            let sk = self.raw(k, true)?;
            let v = sl.1.iter().zip(&sk.1).map(|(a, b)| 2.0 * a - b).collect();
            (2.0 * sl.0 - sk.0, v)
        };
        self.j += 1;
        Ok(Some(out))
    }
}

/// G's rows `start..end` in order.
enum GSource {
    /// No source: the states were computed in memory.
    Empty,
    Direct(PSource),
    Resampled {
        p: PSource,
        /// P knots around the grid times being evaluated.
        knots: VecDeque<(f64, Vec<f64>)>,
        dt: f64,
        /// Grid time of row `index`.
        x: f64,
        p_last: f64,
        index: usize,
        start: usize,
        end: usize,
        labels: Vec<String>,
        pending: VecDeque<(f64, Vec<f64>)>,
        block: usize,
    },
}

impl GSource {
    fn next(&mut self) -> Result<Option<(f64, Vec<f64>)>> {
        match self {
            GSource::Empty => Ok(None),
            GSource::Direct(p) => p.next(),
            GSource::Resampled {
                p,
                knots,
                dt,
                x,
                p_last,
                index,
                start,
                end,
                labels,
                pending,
                block,
            } => {
                if let Some(r) = pending.pop_front() {
                    return Ok(Some(r));
                }
                // skip to the first row wanted
                while *index < *start && *x <= *p_last {
                    *x += *dt;
                    *index += 1;
                }
                if *index >= *end || *x > *p_last {
                    return Ok(None);
                }
                let mut times = Vec::with_capacity(*block);
                while *index < *end && *x <= *p_last && times.len() < *block {
                    times.push(*x);
                    *x += *dt;
                    *index += 1;
                }
                let (t_first, t_last) = (times[0], times[times.len() - 1]);
                let s = SPLINE_OVERLAP + 2;
                loop {
                    let after = knots.iter().rev().take_while(|k| k.0 > t_last).count();
                    if after >= s {
                        break;
                    }
                    match p.next()? {
                        Some(k) => knots.push_back(k),
                        None => break,
                    }
                }
                let before = knots.iter().take_while(|k| k.0 < t_first).count();
                knots.drain(..before.saturating_sub(s));
                let kt: Vec<f64> = knots.iter().map(|k| k.0).collect();
                let mut vals = vec![Vec::with_capacity(labels.len()); times.len()];
                let mut fit = SplineFitter::new(5, &kt);
                for (j, label) in labels.iter().enumerate() {
                    let y: Vec<f64> = knots.iter().map(|k| k.1[j]).collect();
                    let sp = fit
                        .spline(&y)
                        .map_err(|e| e.context(format!("resampling column '{label}'")))?;
                    for (i, &t) in times.iter().enumerate() {
                        vals[i].push(sp.value(t));
                    }
                }
                pending.extend(times.into_iter().zip(vals));
                Ok(pending.pop_front())
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::motion::states::States;
    use crate::parse::setup::Setup;
    use crate::storage::Storage;

    /// Largest |a − b| / max(1, max |b|) per column, over all rows.
    fn worst(a: &[Vec<f64>], b: &[Vec<f64>]) -> f64 {
        let nc = b.first().map_or(0, |r| r.len());
        let mut w = 0.0f64;
        for c in 0..nc {
            let scale = b.iter().map(|r| r[c].abs()).fold(1.0f64, f64::max);
            for (ra, rb) in a.iter().zip(b) {
                w = w.max((ra[c] - rb[c]).abs() / scale);
            }
        }
        w
    }

    /// q to 1e-12; u and u̇ to 1e-12 or 10× the in-memory path's own
    /// rounding noise (u̇ is a second derivative: its noise reaches ~1e-11 of
    /// its range near the ends; the windows change the rounding of the
    /// filter and of the spline solves). That the differences are rounding,
    /// not truncation: on the uniform 12,000-row motion, filter overlaps for
    /// 1e-18, 1e-24, 1e-30 and 1e-40 gave worst u̇ differences of 2.5e-11,
    /// 4.5e-11, 9.1e-12 and 4.3e-11 (not decreasing), q's stayed 4–5e-14.
    fn within(w: &[f64; 3], floor: &[f64; 2]) -> bool {
        w[0] <= 1e-12
            && w[1] <= 1e-12f64.max(10.0 * floor[0])
            && w[2] <= 1e-12f64.max(10.0 * floor[1])
    }

    /// Stream everything and compare with the in-memory path; returns the
    /// worst relative differences (q, u, u̇) and whether all were bitwise equal.
    fn compare(
        model: &Model,
        file: &Path,
        cutoff: f64,
        range: (f64, f64),
        block: usize,
        noise: &mut [f64; 2],
    ) -> ([f64; 3], bool, usize) {
        let table = crate::tools::loading::load_coordinates(file, cutoff).unwrap();
        let states = States::from_coordinates(model, &table, file).unwrap();
        let udot = states.speed_derivatives(file).unwrap();
        let rows = crate::tools::analyze::frame_rows(&states.time, range.0, range.1, 1);
        let mut s =
            StateStream::open_with_block(model, file, cutoff, range.0, range.1, block).unwrap();
        assert_eq!(s.rows, states.time.len());
        assert_eq!(s.first_time, states.time[0]);
        assert_eq!(s.last_time, *states.time.last().unwrap());
        assert_eq!(s.missing, states.missing);
        assert_eq!(s.first_row, rows[0]);
        assert_eq!(s.last_row, *rows.last().unwrap());
        let (mut q, mut u, mut ud) = (Vec::new(), Vec::new(), Vec::new());
        let mut next = rows[0];
        while let Some(b) = s.next_block().unwrap() {
            assert_eq!(b.first, next);
            for (i, &t) in b.time.iter().enumerate() {
                assert_eq!(t, states.time[next + i], "time of row {}", next + i);
            }
            next += b.time.len();
            q.extend(b.q);
            u.extend(b.u);
            ud.extend(b.udot);
        }
        assert_eq!(next, rows.last().unwrap() + 1);
        let r = rows[0]..=*rows.last().unwrap();
        let (wq, wu, wd) = (&states.q[r.clone()], &states.u[r.clone()], &udot[r]);
        let bitwise = q == wq && u == wu && ud == wd;
        // The in-memory path's own rounding noise: its u̇ after a 1-ulp
        // relative perturbation of the filtered coordinates.
        // The in-memory path's own rounding noise: its results for the
        // coordinates scaled by 1.1 before filtering, scaled back (the chain
        // is linear, so only the rounding differs).
        let floor = {
            let mut t2 = crate::storage::read(file).unwrap();
            for r in t2.rows.iter_mut() {
                for v in r.iter_mut() {
                    *v *= 1.1;
                }
            }
            if cutoff >= 0.0 {
                let n = t2.time.len() / 2;
                crate::motion::filter::pad(&mut t2, n);
                crate::motion::filter::lowpass_iir(&mut t2, cutoff).unwrap();
            }
            let s2 = States::from_coordinates(model, &t2, file).unwrap();
            let ud2 = s2.speed_derivatives(file).unwrap();
            let r = rows[0]..=*rows.last().unwrap();
            let back = |m: &[Vec<f64>]| -> Vec<Vec<f64>> {
                m.iter()
                    .map(|row| row.iter().map(|v| v / 1.1).collect())
                    .collect()
            };
            [
                worst(&back(&s2.u[r.clone()]), wu),
                worst(&back(&ud2[r]), wd),
            ]
        };
        *noise = floor;
        (
            [worst(&q, wq), worst(&u, wu), worst(&ud, wd)],
            bitwise,
            q.len(),
        )
    }

    /// Every validation case's coordinates: the stream equals the in-memory
    /// states (q, u, u̇) — bitwise when the motion fits in one block, to
    /// 1e-12 relative with small blocks (windows with overlaps, the true ends
    /// handled exactly), over the whole table and over the setup's range.
    #[test]
    fn equals_in_memory_on_validation_cases() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/validation");
        if !root.is_dir() {
            println!("SKIP: {} absent", root.display());
            return;
        }
        for case in ["arm26", "leg6dof9musc_stance", "gait10dof18musc_walk"] {
            let Setup::Analyze(setup) = Setup::read(&root.join(case).join("setup_SO.xml")).unwrap()
            else {
                panic!("{case}: not an AnalyzeTool setup")
            };
            let (_, model) = crate::tools::loading::load_model(&setup.model_file).unwrap();
            let file = setup.coordinates_file.clone().unwrap();
            for cutoff in [setup.lowpass_cutoff, -1.0] {
                for range in [
                    (f64::NEG_INFINITY, f64::INFINITY),
                    (setup.initial_time, setup.final_time),
                ] {
                    let (w, bitwise, n) =
                        compare(&model, &file, cutoff, range, DEFAULT_BLOCK, &mut [0.0; 2]);
                    assert!(
                        bitwise,
                        "{case} cutoff {cutoff}: one block not bitwise {w:?}"
                    );
                    for block in [5, 37] {
                        let (w, _, n2) =
                            compare(&model, &file, cutoff, range, block, &mut [0.0; 2]);
                        assert_eq!(n, n2);
                        assert!(
                            w.iter().all(|&x| x <= 1e-12),
                            "{case} cutoff {cutoff} range {range:?} block {block}: {w:?}"
                        );
                        println!("{case} cutoff {cutoff} range {range:?} block {block}: {n} rows, worst relative q {:.1e} u {:.1e} udot {:.1e}", w[0], w[1], w[2]);
                    }
                }
            }
        }
    }

    /// A long synthetic motion (irregular sampling, so resampling and the
    /// filter's and splines' overlaps are all exercised far from the ends)
    /// on the arm26 model: the stream equals the in-memory path.
    #[test]
    fn equals_in_memory_on_long_motion() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/validation");
        if !root.is_dir() {
            println!("SKIP: {} absent", root.display());
            return;
        }
        let (_, model) =
            crate::tools::loading::load_model(&root.join("arm26/inputs/arm26.osim")).unwrap();
        let tmp = crate::test_dir::TempDir::new("statopt-stream");
        let dir = tmp.path().to_path_buf();
        let n = 12_000;
        let mut table = Storage {
            name: "synthetic".into(),
            labels: vec!["r_shoulder_elev".into(), "r_elbow_flex".into()],
            in_degrees: true,
            ..Default::default()
        };
        let mut t = 0.0;
        for i in 0..n {
            // steps alternate 0.01 and 0.012: non-uniform
            t += if i % 2 == 0 { 0.01 } else { 0.012 };
            table.time.push(t);
            table.rows.push(vec![
                30.0 * (1.3 * t).sin() + 5.0 * (7.0 * t).cos(),
                60.0 + 40.0 * (0.7 * t).sin() * (2.1 * t).cos(),
            ]);
        }
        for (name, table) in [
            ("irregular", table.clone()),
            ("uniform", {
                let mut u = table.clone();
                for (i, t) in u.time.iter_mut().enumerate() {
                    *t = 0.005 * i as f64;
                }
                u
            }),
        ] {
            let file = dir.join(format!("{name}.mot"));
            let (t0, tl) = (table.time[0], table.time[n - 1]);
            let span = tl - t0;
            crate::storage::write(&file, &table, 10).unwrap();
            for (cutoff, range) in [
                (6.0, (f64::NEG_INFINITY, f64::INFINITY)),
                (6.0, (20.0, 40.0)),
                // frames deep in the leading and trailing padding
                (6.0, (t0 - 0.4 * span, t0 - 0.1 * span)),
                (6.0, (tl + 0.1 * span, tl + 0.4 * span)),
                (-1.0, (f64::NEG_INFINITY, f64::INFINITY)),
                (-1.0, (20.0, 40.0)),
            ] {
                let mut floor = [0.0; 2];
                let (w, _, rows) = compare(&model, &file, cutoff, range, 1000, &mut floor);
                println!(
                    "{name} {n} rows, cutoff {cutoff}, range {range:?}: {rows} states rows, worst relative q {:.1e} u {:.1e} udot {:.1e} (in-memory path's own rounding noise: u {:.1e}, udot {:.1e})",
                    w[0], w[1], w[2], floor[0], floor[1]
                );
                assert!(
                    within(&w, &floor),
                    "{name} {cutoff} {range:?}: {w:?}, noise {floor:?}"
                );
            }
        }
        let _ = std::fs::remove_dir_all(&dir);
    }

    /// A TimeSeriesTable (version 3) coordinates file is read whole and
    /// streamed from memory: same states.
    #[test]
    fn time_series_table_input() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/validation");
        if !root.is_dir() {
            println!("SKIP: {} absent", root.display());
            return;
        }
        let (_, model) =
            crate::tools::loading::load_model(&root.join("arm26/inputs/arm26.osim")).unwrap();
        let tmp = crate::test_dir::TempDir::new("statopt-stream-v3");
        let dir = tmp.path().to_path_buf();
        let mut text = String::from("version=3\nOpenSimVersion=4.6\ninDegrees=yes\nDataType=double\nendheader\ntime\tr_shoulder_elev\tr_elbow_flex\n");
        for i in 0..700 {
            let t = 0.01 * i as f64 + if i % 3 == 0 { 0.002 } else { 0.0 };
            text.push_str(&format!(
                "{t}\t{}\t{}\n",
                20.0 * (2.0 * t).sin(),
                50.0 + 30.0 * t.cos()
            ));
        }
        let file = dir.join("v3.sto");
        std::fs::write(&file, text).unwrap();
        for cutoff in [6.0, -1.0] {
            let mut floor = [0.0; 2];
            let (w, _, _) = compare(
                &model,
                &file,
                cutoff,
                (f64::NEG_INFINITY, f64::INFINITY),
                100,
                &mut floor,
            );
            println!("v3 cutoff {cutoff}: worst relative q {:.1e} u {:.1e} udot {:.1e} (noise u {:.1e}, udot {:.1e})", w[0], w[1], w[2], floor[0], floor[1]);
            assert!(
                within(&w, &floor),
                "cutoff {cutoff}: {w:?}, noise {floor:?}"
            );
        }
        let _ = std::fs::remove_dir_all(&dir);
    }
}
