//! The table and figure of `statopt-tool emg-compare` (docs/emg_compare.md):
//! the agreement of activations with EMG (`metrics::emg`) per activation
//! file and channel.

use std::path::{Path, PathBuf};

use crate::error::{Error, Location, Result};
use crate::metrics::emg::Comparison;
use crate::plots;

/// The columns of [`write_csv`]'s table.
pub const CSV_COLUMNS: [&str; 8] = [
    "activations",
    "channel",
    "muscles",
    "r",
    "on_off_agreement",
    "best_delay_ms",
    "r_at_best_delay",
    "activation_peak",
];

/// One row per activation file and channel, then a `mean` row per file.
pub fn write_csv(comparisons: &[Comparison], path: &Path) -> Result<()> {
    let err = |e: csv::Error| Error::input(Location::file(path), format!("cannot write CSV: {e}"));
    let mut w = csv::Writer::from_path(path).map_err(err)?;
    w.write_record(CSV_COLUMNS).map_err(err)?;
    let opt = |v: Option<f64>| v.map(|x| format!("{x:.4}")).unwrap_or_default();
    for c in comparisons {
        for ch in &c.channels {
            let peak = ch
                .activation
                .iter()
                .cloned()
                .fold(f64::NEG_INFINITY, f64::max);
            w.write_record([
                c.label.clone(),
                ch.channel.clone(),
                ch.muscles.join(" "),
                opt(ch.r),
                format!("{:.4}", ch.on_off),
                opt(ch.best_delay_ms),
                opt(ch.best_r),
                format!("{peak:.4}"),
            ])
            .map_err(err)?;
        }
        w.write_record([
            c.label.clone(),
            "mean".into(),
            String::new(),
            opt(c.mean_r()),
            format!("{:.4}", c.mean_on_off()),
            String::new(),
            String::new(),
            String::new(),
        ])
        .map_err(err)?;
    }
    w.flush().map_err(|e| Error::io(path, e))
}

/// A panel per channel: the EMG and each file's activation, each divided by
/// its peak over the compared frames (the legend gives the activation's
/// peak and r). Writes `<stem>.png` and `<stem>.svg`.
pub fn write_figure(comparisons: &[Comparison], delay: f64, stem: &Path) -> Result<Vec<PathBuf>> {
    let Some(first) = comparisons.first() else {
        return Err(Error::msg("no activation file to draw"));
    };
    let norm = |v: &[f64]| -> Vec<f64> {
        let p = v.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
        v.iter()
            .map(|x| if p > 0.0 { x / p } else { 0.0 })
            .collect()
    };
    let charts: Vec<plots::Chart> = (0..first.channels.len())
        .map(|k| {
            let ch = &first.channels[k];
            let mut chart = plots::Chart {
                title: format!("{} ({})", ch.channel, ch.muscles.join(", ")),
                x_label: "time (s)".into(),
                y_label: "of its peak".into(),
                ..Default::default()
            };
            chart.series.push(plots::Series::new(
                if delay == 0.0 {
                    "EMG".to_string()
                } else {
                    format!("EMG {:.0} ms earlier", 1e3 * delay)
                },
                first.time.clone(),
                norm(&ch.emg),
                plots::Style::color(7),
            ));
            for (i, c) in comparisons.iter().enumerate() {
                let cr = &c.channels[k];
                let peak = cr
                    .activation
                    .iter()
                    .cloned()
                    .fold(f64::NEG_INFINITY, f64::max);
                let r =
                    cr.r.map(|r| format!("{r:.2}"))
                        .unwrap_or_else(|| "n/a".into());
                chart.series.push(plots::Series::new(
                    format!("{}: r {r}, peak a {peak:.2}", c.label),
                    c.time.clone(),
                    norm(&cr.activation),
                    plots::Style::color(i),
                ));
            }
            chart
        })
        .collect();
    let cols = 2;
    let rows = charts.len().div_ceil(cols);
    plots::write_panels(
        &charts,
        stem,
        plots::Layout {
            rows,
            cols,
            size: (1000 * cols as u32, 420 * rows as u32),
        },
    )
}

/// `<stem>.csv`, the stem kept whole (`out/share_0.5` → `out/share_0.5.csv`).
pub fn csv_path(stem: &Path) -> PathBuf {
    let mut s = stem.as_os_str().to_owned();
    s.push(".csv");
    PathBuf::from(s)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A stem with a dot keeps it: the table of `share_0.5` is not `share_0.csv`.
    #[test]
    fn csv_path_keeps_the_stem() {
        assert_eq!(
            csv_path(Path::new("o/share_0.5")),
            Path::new("o/share_0.5.csv")
        );
        assert_eq!(csv_path(Path::new("cmp")), Path::new("cmp.csv"));
    }
}
