//! A `<Metric>`'s statistic of a series (`plan::figures::MetricOp`): of a
//! table's column (`tools::figures`) or of a force sweep's candidate, whose
//! series are never written (`sweep`).

use crate::error::Result;
use crate::plan::figures::MetricOp;

/// A `<Metric>`'s value (its op) over the series `y` at times `t`;
/// `where_column` gives its `where` column's values when the op needs them
/// (the plan holds one for every such op). (Force sweeps compute their
/// candidates' metrics with it, from series they never write:
/// `sweep`; a study's `<Metric>`s from its tables: `tools::figures`.)
pub fn metric_value(
    op: MetricOp,
    t: &[f64],
    y: &[f64],
    where_column: impl Fn() -> Result<Vec<f64>>,
) -> Result<f64> {
    Ok(match op {
        MetricOp::Max => y.iter().cloned().fold(f64::NEG_INFINITY, f64::max),
        MetricOp::Min => y.iter().cloned().fold(f64::INFINITY, f64::min),
        MetricOp::AbsMax => y.iter().fold(0.0f64, |m, v| m.max(v.abs())),
        MetricOp::Mean => y.iter().sum::<f64>() / y.len().max(1) as f64,
        MetricOp::Integral => t
            .windows(2)
            .zip(y.windows(2))
            .map(|(t, y)| 0.5 * (y[0] + y[1]) * (t[1] - t[0]))
            .sum(),
        MetricOp::ArgMax | MetricOp::ArgMin => {
            let w = where_column()?;
            let better = |a: f64, b: f64| {
                if op == MetricOp::ArgMax {
                    a > b
                } else {
                    a < b
                }
            };
            let mut k = 0;
            for i in 1..y.len() {
                if better(y[i], y[k]) {
                    k = i;
                }
            }
            w.get(k).copied().unwrap_or(f64::NAN)
        }
        MetricOp::At(x) => {
            let w = where_column()?;
            crossing(&w, y, |i| w[i] - x).unwrap_or(f64::NAN)
        }
        MetricOp::Crossing => {
            let w = where_column()?;
            crossing(y, &w, |i| y[i]).unwrap_or(f64::NAN)
        }
    })
}

/// `out` linearly interpolated at the first sign change of `f(i)` (i over
/// the rows of `key`); None when `f` keeps one sign.
fn crossing(key: &[f64], out: &[f64], f: impl Fn(usize) -> f64) -> Option<f64> {
    let _ = key;
    (1..out.len()).find_map(|i| {
        let (a, b) = (f(i - 1), f(i));
        if a == 0.0 {
            Some(out[i - 1])
        } else if a * b < 0.0 || b == 0.0 {
            let s = a / (a - b);
            Some(out[i - 1] + s * (out[i] - out[i - 1]))
        } else {
            None
        }
    })
}
