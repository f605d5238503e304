//! The statistics of a contact-weight sweep: mean, minimum and maximum of
//! every column over the sweep's runs, frame by frame, as tables beside
//! the runs' own.

use crate::error::{Error, Result};
use crate::storage::StoWriter;

/// Mean, minimum and maximum over the runs of a sweep, per column and frame
/// (the paper's uncertainty band, section 3.2). The runs' tables are read
/// row by row in step, so memory does not grow with the trial's length.
/// `stat_path` names the table of each statistic (`writers::names`).
pub fn write_sweep_statistics(
    setup_file: &std::path::Path,
    files: &[std::path::PathBuf],
    stat_path: &dyn Fn(crate::writers::names::Stat) -> std::path::PathBuf,
    kind: &str,
    weights: &[f64],
    precision: usize,
) -> Result<Vec<std::path::PathBuf>> {
    let mut readers = files
        .iter()
        .map(|f| crate::storage::open_rows(f))
        .collect::<Result<Vec<_>>>()?;
    let labels = readers[0].table.labels.clone();
    for (r, f) in readers.iter().zip(files).skip(1) {
        if r.table.labels != labels {
            return Err(Error::internal(format!(
                "{}: its columns differ from {}'s",
                f.display(),
                files[0].display()
            )));
        }
    }
    use crate::writers::names::Stat;
    let stats = Stat::ALL;
    let mut out = Vec::new();
    let mut writers = Vec::new();
    for stat in stats {
        let path = stat_path(stat);
        let stat = stat.as_str();
        let desc = format!("{stat} over contact weights w0 = {weights:?} of the static optimization {kind} results.\n");
        writers.push(StoWriter::create_for_setup(
            setup_file,
            &path,
            &format!("{kind} {stat}"),
            &desc,
            &labels,
            precision,
            false,
        )?);
        out.push(path);
    }
    let nl = labels.len();
    let mut rows = vec![Vec::with_capacity(nl); readers.len()];
    let mut row = vec![0.0; nl];
    'frames: loop {
        let mut time = None;
        for (k, (r, buf)) in readers.iter_mut().zip(rows.iter_mut()).enumerate() {
            match (r.next_row(buf)?, k) {
                (None, 0) => break 'frames,
                (None, _) => {
                    return Err(Error::internal(format!(
                        "{}: fewer rows than {}",
                        files[k].display(),
                        files[0].display()
                    )))
                }
                (Some(t), 0) => time = Some(t),
                (Some(_), _) => {}
            }
        }
        let t = time.expect("the first table's row");
        for (stat, w) in stats.iter().zip(writers.iter_mut()) {
            for (j, v) in row.iter_mut().enumerate() {
                let vals = rows.iter().map(|r| r[j]);
                *v = match *stat {
                    Stat::Mean => vals.sum::<f64>() / rows.len() as f64,
                    Stat::Min => vals.fold(f64::INFINITY, f64::min),
                    Stat::Max => vals.fold(f64::NEG_INFINITY, f64::max),
                };
            }
            w.write_row(t, &row)?;
        }
    }
    for w in writers {
        w.finish()?;
    }
    Ok(out)
}
