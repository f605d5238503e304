//! A JointReaction's forces file (opensim-semantics.md §7.2): the
//! actuators' forces per frame, interpolated in time as OpenSim's
//! `Storage::getDataAtTime`, read window by window as the frames need it.

use std::path::{Path, PathBuf};

use crate::error::{Error, Result};
use crate::storage::{self, Storage};

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
    pub(crate) fn streamed(path: &Path, header: Storage) -> Self {
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
    pub(crate) fn values_at(&self, t: f64, cols: &[usize]) -> Result<Vec<f64>> {
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

#[cfg(test)]
mod tests {
    use super::*;

    /// A forces file read window by window gives the values of the whole
    /// table: frames in blocks moving forward (the window drops the rows
    /// behind), frames asked without `prepare`, times before the first row,
    /// past the last and back to the start (the file is read again).
    #[test]
    fn forces_file_window_equals_the_whole_table() {
        let tmp = crate::test_dir::TempDir::new("statopt_jr_window");
        let dir = tmp.path().to_path_buf();
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
}
