//! Differences between a run's results tables and a reference run's, at
//! the reference's rows or interpolated between them (`statopt-tool bench
//! --grid`: each method choice's error against the reference choice).

use crate::storage::Storage;

/// The row of `reference` at time `t`: the row with that time (within
/// 1e-9 s), else linear interpolation between the neighbouring rows (runs
/// whose frames differ, e.g. a filter that resamples a non-uniform motion);
/// None outside the reference's time range.
pub fn row_at(reference: &Storage, t: f64) -> Option<Vec<f64>> {
    let n = reference.time.len();
    let i = reference.time.partition_point(|&x| x < t - 1e-9);
    if i < n && (reference.time[i] - t).abs() <= 1e-9 {
        return Some(reference.rows[i].clone());
    }
    if i == 0 || i >= n {
        return None;
    }
    let (t0, t1) = (reference.time[i - 1], reference.time[i]);
    let w = (t - t0) / (t1 - t0);
    Some(
        reference.rows[i - 1]
            .iter()
            .zip(&reference.rows[i])
            .map(|(a, b)| a + w * (b - a))
            .collect(),
    )
}

/// (max, RMS) of |Δ| over the common columns and times.
pub fn scalar_errors(ours: &Storage, reference: &Storage) -> (f64, f64) {
    let cols: Vec<(usize, usize)> = reference
        .labels
        .iter()
        .enumerate()
        .filter_map(|(j, l)| ours.column_index(l).map(|k| (k, j)))
        .collect();
    let (mut max, mut sum, mut n) = (0.0f64, 0.0, 0usize);
    for (i, &t) in ours.time.iter().enumerate() {
        let Some(r) = row_at(reference, t) else {
            continue;
        };
        for &(k, j) in &cols {
            let d = (ours.rows[i][k] - r[j]).abs();
            let d = if d.is_nan() { f64::INFINITY } else { d };
            max = max.max(d);
            sum += d * d;
            n += 1;
        }
    }
    if n == 0 {
        return (f64::NAN, f64::NAN);
    }
    (max, (sum / n as f64).sqrt())
}

/// Max norm of Δ of the vectors `<root>_fx/_fy/_fz` for the given roots.
pub fn vector_error(ours: &Storage, reference: &Storage, roots: &[String]) -> f64 {
    let mut max = 0.0f64;
    let mut any = false;
    for root in roots {
        let idx = |t: &Storage| -> Option<[usize; 3]> {
            Some([
                t.column_index(&format!("{root}_fx"))?,
                t.column_index(&format!("{root}_fy"))?,
                t.column_index(&format!("{root}_fz"))?,
            ])
        };
        let (Some(a), Some(b)) = (idx(ours), idx(reference)) else {
            continue;
        };
        for (i, &t) in ours.time.iter().enumerate() {
            let Some(r) = row_at(reference, t) else {
                continue;
            };
            any = true;
            let d: f64 = (0..3)
                .map(|c| (ours.rows[i][a[c]] - r[b[c]]).powi(2))
                .sum::<f64>()
                .sqrt();
            max = max.max(if d.is_nan() { f64::INFINITY } else { d });
        }
    }
    if any {
        max
    } else {
        f64::NAN
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn table(labels: &[&str], time: &[f64], rows: &[&[f64]]) -> Storage {
        Storage {
            name: "t".into(),
            labels: labels.iter().map(|l| l.to_string()).collect(),
            time: time.to_vec(),
            rows: rows.iter().map(|r| r.to_vec()).collect(),
            in_degrees: false,
            metadata: Vec::new(),
        }
    }

    /// Errors of known tables: rows matched by time or interpolated, columns
    /// by label, a time outside the reference skipped, NaN as infinite.
    #[test]
    fn differences_of_known_tables() {
        let reference = table(&["a", "b"], &[0.0, 1.0], &[&[0.0, 10.0], &[2.0, 20.0]]);
        // t = 0.5 interpolates to (1, 15); t = 2 is outside and skipped.
        assert_eq!(row_at(&reference, 0.5), Some(vec![1.0, 15.0]));
        assert_eq!(row_at(&reference, 1.0 + 1e-12), Some(vec![2.0, 20.0]));
        assert_eq!(row_at(&reference, 2.0), None);
        let ours = table(
            &["b", "a", "c"],
            &[0.0, 0.5, 2.0],
            &[&[13.0, 4.0, 0.0], &[15.0, 1.0, 9.0], &[0.0, 0.0, 0.0]],
        );
        // |Δ| = 3, 4 at t = 0 and 0, 0 at t = 0.5: max 4, RMS sqrt(25/4).
        let (max, rms) = scalar_errors(&ours, &reference);
        assert_eq!(max, 4.0);
        assert!((rms - 2.5).abs() < 1e-15, "{rms}");
        let mut bad = ours.clone();
        bad.rows[1][1] = f64::NAN;
        assert_eq!(scalar_errors(&bad, &reference).0, f64::INFINITY);
        let none = table(&["x"], &[0.0], &[&[1.0]]);
        assert!(scalar_errors(&none, &reference).0.is_nan());
        // Vectors <root>_fx/_fy/_fz: the norm of the difference.
        let labels = ["k_fx", "k_fy", "k_fz"];
        let reference = table(&labels, &[0.0], &[&[1.0, 2.0, 3.0]]);
        let ours = table(&labels, &[0.0], &[&[4.0, 6.0, 3.0]]);
        assert_eq!(vector_error(&ours, &reference, &["k".to_string()]), 5.0);
        assert!(vector_error(&ours, &reference, &["j".to_string()]).is_nan());
    }
}
