//! OpenSim's coordinate preprocessing (opensim-semantics.md §9.2 step 2;
//! `Storage::pad`, `Storage::lowpassIIR`, `Storage::resample`,
//! `Signal::Pad`, `Signal::LowpassIIR`): reflect-and-negate padding, resampling
//! at the smallest time step with quintic interpolating splines, and a
//! third-order Butterworth low-pass filter run forward and backward.

use crate::error::{Error, Result};
use crate::functions::GcvSpline;
use crate::storage::Storage;

/// OpenSim's `Storage::MAX_RESAMPLE_SIZE`.
const MAX_RESAMPLE_SIZE: f64 = 100_000.0;

/// `Signal::Pad` on one signal: prepend and append `pad` points reflected
/// about each end point and negated, preserving value and slope there.
/// A pad as large as the signal is applied repeatedly, as OpenSim does.
pub fn pad_signal(pad: usize, s: &[f64]) -> Vec<f64> {
    if pad == 0 || s.is_empty() {
        return s.to_vec();
    }
    let size = s.len();
    let new_size = size + 2 * pad;
    if pad >= size {
        if size < 2 {
            return s.to_vec();
        }
        let mut v = s.to_vec();
        let mut p = size - 1;
        while v.len() < new_size {
            v = pad_signal(p, &v);
            p = (new_size - v.len()) / 2;
            if p >= v.len() {
                p = v.len() - 1;
            }
            if p == 0 {
                break;
            }
        }
        return v;
    }
    let mut out = Vec::with_capacity(new_size);
    for i in 0..pad {
        out.push(2.0 * s[0] - s[pad - i]);
    }
    out.extend_from_slice(s);
    for i in 0..pad {
        out.push(2.0 * s[size - 1] - s[size - 2 - i]);
    }
    out
}

/// `Storage::pad`: pad the time column and every data column.
pub fn pad(table: &mut Storage, n: usize) {
    if n == 0 || table.time.is_empty() {
        return;
    }
    let time = pad_signal(n, &table.time);
    let ncol = table.labels.len();
    let cols: Vec<Vec<f64>> = (0..ncol).map(|j| pad_signal(n, &table.column(j))).collect();
    table.rows = (0..time.len())
        .map(|i| cols.iter().map(|c| c[i]).collect())
        .collect();
    table.time = time;
}

fn min_time_step(time: &[f64]) -> f64 {
    time.windows(2)
        .map(|w| w[1] - w[0])
        .fold(f64::INFINITY, f64::min)
}

/// `Storage::resample(dt, degree)`: every column through an interpolating GCV
/// spline of `degree`, sampled at t = t_first, t_first + dt, ... (repeated
/// floating-point addition) while t <= t_last. Returns the step used.
pub fn resample(table: &mut Storage, dt: f64, degree: usize) -> Result<f64> {
    let n = table.time.len();
    if n <= 1 {
        return Ok(dt);
    }
    let (first, last) = (table.time[0], table.time[n - 1]);
    let dt = if (last - first) / dt > MAX_RESAMPLE_SIZE {
        (last - first) / MAX_RESAMPLE_SIZE
    } else {
        dt
    };
    let splines = (0..table.labels.len())
        .map(|j| {
            GcvSpline::interpolating(degree, &table.time, &table.column(j))
                .map_err(|e| e.context(format!("resampling column '{}'", table.labels[j])))
        })
        .collect::<Result<Vec<_>>>()?;
    let mut time = Vec::new();
    let mut x = first;
    while x <= last {
        time.push(x);
        x += dt;
    }
    table.rows = time
        .iter()
        .map(|&t| splines.iter().map(|s| s.value(t)).collect())
        .collect();
    table.time = time;
    Ok(dt)
}

/// `Signal::LowpassIIR`: third-order Butterworth (bilinear transform with
/// pre-warping), applied forward then backward; the first three outputs of
/// each pass equal its inputs.
pub fn lowpass_signal(dt: f64, cutoff: f64, sig: &[f64]) -> Vec<f64> {
    let n = sig.len();
    if n < 4 || dt == 0.0 {
        return sig.to_vec();
    }
    let fs = 1.0 / dt;
    let fc = if cutoff >= 0.5 * fs {
        0.49 * fs
    } else {
        cutoff
    };
    let wc = 2.0 * std::f64::consts::PI * fc;
    let wa = (wc * dt / 2.0).tan();
    let (wa2, wa3) = (wa * wa, wa * wa * wa);
    let denom = (wa + 1.0) * (wa * wa + wa + 1.0);
    let a = [
        wa3 / denom,
        3.0 * wa3 / denom,
        3.0 * wa3 / denom,
        wa3 / denom,
    ];
    let b = [
        1.0,
        (3.0 * wa3 + 2.0 * wa2 - 2.0 * wa - 3.0) / denom,
        (3.0 * wa3 - 2.0 * wa2 - 2.0 * wa + 3.0) / denom,
        (wa - 1.0) * (wa2 - wa + 1.0) / denom,
    ];
    let pass = |x: &[f64]| -> Vec<f64> {
        let mut y = vec![0.0; n];
        y[..4].copy_from_slice(&x[..4]);
        for i in 3..n {
            y[i] = a[0] * x[i] + a[1] * x[i - 1] + a[2] * x[i - 2] + a[3] * x[i - 3]
                - b[1] * y[i - 1]
                - b[2] * y[i - 2]
                - b[3] * y[i - 3];
        }
        y
    };
    let mut fwd = pass(sig);
    fwd.reverse();
    let mut back = pass(&fwd);
    back.reverse();
    back
}

/// `Storage::lowpassIIR`: resample at the smallest time step when the
/// sampling is not uniform (average step exceeds the smallest by more than
/// machine epsilon), then filter every column.
pub fn lowpass_iir(table: &mut Storage, cutoff: f64) -> Result<()> {
    let n = table.time.len();
    if n < 2 {
        return Ok(());
    }
    let mut dt = min_time_step(&table.time);
    if dt < f64::EPSILON {
        return Err(Error::msg(format!("the time column has a step of {dt}: rows must have strictly increasing times to be filtered")));
    }
    let avg = (table.time[n - 1] - table.time[0]) / (n - 1) as f64;
    if avg - dt > f64::EPSILON {
        dt = resample(table, dt, 5)?;
    }
    if table.time.len() < 4 {
        return Ok(());
    }
    for j in 0..table.labels.len() {
        let f = lowpass_signal(dt, cutoff, &table.column(j));
        table.set_column(j, &f);
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pad_reflects_and_negates() {
        let s = [1.0, 2.0, 4.0, 7.0];
        assert_eq!(
            pad_signal(2, &s),
            vec![-2.0, 0.0, 1.0, 2.0, 4.0, 7.0, 10.0, 12.0]
        );
        // a pad larger than the signal is applied repeatedly
        assert_eq!(pad_signal(5, &s).len(), 14);
    }

    #[test]
    fn butterworth_passes_dc_and_attenuates_high_frequency() {
        let dt = 0.01;
        let dc = vec![3.0; 400];
        assert!(lowpass_signal(dt, 6.0, &dc)
            .iter()
            .all(|v| (v - 3.0).abs() < 1e-12));
        // 40 Hz through a 6 Hz zero-phase 6th-order filter: gain (6/40)^6 ≈ 1e-5
        let hf: Vec<f64> = (0..400)
            .map(|i| (2.0 * std::f64::consts::PI * 40.0 * i as f64 * dt).sin())
            .collect();
        let f = lowpass_signal(dt, 6.0, &hf);
        let peak = f[100..300].iter().fold(0.0f64, |m, v| m.max(v.abs()));
        assert!(peak < 1e-3, "{peak}");
        // at the cut-off the zero-phase gain is 1/2 (-6 dB)
        let fc: Vec<f64> = (0..2000)
            .map(|i| (2.0 * std::f64::consts::PI * 6.0 * i as f64 * dt).sin())
            .collect();
        let f = lowpass_signal(dt, 6.0, &fc);
        let peak = f[800..1200].iter().fold(0.0f64, |m, v| m.max(v.abs()));
        assert!((peak - 0.5).abs() < 0.01, "{peak}");
    }
}
