//! OpenSim's coordinate preprocessing (opensim-semantics.md §9.2 step 2;
//! `Storage::pad`, `Storage::lowpassIIR`, `Storage::resample`,
//! `Signal::Pad`, `Signal::LowpassIIR`): reflect-and-negate padding, resampling
//! at the smallest time step with quintic interpolating splines, and a
//! third-order Butterworth low-pass filter run forward and backward.

use std::path::Path;

use crate::error::{Error, Result};
use crate::functions::SplineFitter;
use crate::storage::{self, Storage};

/// OpenSim's `Storage::MAX_RESAMPLE_SIZE`.
pub const MAX_RESAMPLE_SIZE: f64 = 100_000.0;

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

pub fn min_time_step(time: &[f64]) -> f64 {
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
    let mut fit = SplineFitter::new(degree, &table.time);
    let splines = (0..table.labels.len())
        .map(|j| {
            fit.spline(&table.column(j))
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

/// Coefficients (a = numerator, b = denominator, b[0] = 1) of
/// `Signal::LowpassIIR`'s third-order Butterworth filter (bilinear transform
/// with pre-warping) for sampling step `dt` and cut-off `cutoff`.
pub fn butterworth(dt: f64, cutoff: f64) -> ([f64; 4], [f64; 4]) {
    let fs = 1.0 / dt;
    let fc = if cutoff >= 0.5 * fs {
        0.49 * fs
    } else {
        cutoff
    };
    // OpenSim computes `2*SimTK_PI*fc` with SimTK_PI a long double literal.
    let wc = two_pi_long_double_times(fc);
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
    (a, b)
}

/// Largest pole radius of the filter `butterworth` returns: the factor by
/// which the influence of a sample (or of the initial conditions) on later
/// outputs shrinks per step. The denominator factors as
/// ((1+wa) z − (1−wa))·((wa²+wa+1) z² + 2(wa²−1) z + (wa²−wa+1)); the
/// quadratic's roots are complex (discriminant −12 wa² < 0) with radius
/// √((wa²−wa+1)/(wa²+wa+1)). Computed from the coefficients b: the real pole
/// is found by Newton's method on z³ + b₁z² + b₂z + b₃ and the pair's radius
/// from the product of the roots, −b₃ / real pole.
pub fn pole_radius(b: &[f64; 4]) -> f64 {
    let p = |z: f64| ((z + b[1]) * z + b[2]) * z + b[3];
    let dp = |z: f64| (3.0 * z + 2.0 * b[1]) * z + b[2];
    // The real root lies in (-1, 1) for a stable filter; start at 1.
    let mut z = 1.0;
    for _ in 0..200 {
        let d = dp(z);
        if d == 0.0 {
            break;
        }
        let step = p(z) / d;
        z -= step;
        if step.abs() < 1e-17 {
            break;
        }
    }
    let pair = if z != 0.0 {
        (-b[3] / z).abs().sqrt()
    } else {
        0.0
    };
    let r = z.abs().max(pair);
    if r.is_finite() {
        r
    } else {
        1.0
    }
}

/// One causal pass of the filter over `x`: the first three outputs equal the
/// inputs (OpenSim's initial conditions), then the difference equation.
pub fn iir_pass(a: &[f64; 4], b: &[f64; 4], x: &[f64]) -> Vec<f64> {
    let n = x.len();
    let mut y = x.to_vec();
    for i in 3..n {
        y[i] = a[0] * x[i] + a[1] * x[i - 1] + a[2] * x[i - 2] + a[3] * x[i - 3]
            - b[1] * y[i - 1]
            - b[2] * y[i - 2]
            - b[3] * y[i - 3];
    }
    y
}

/// `Signal::LowpassIIR`: third-order Butterworth (bilinear transform with
/// pre-warping), applied forward then backward; the first three outputs of
/// each pass equal its inputs.
pub fn lowpass_signal(dt: f64, cutoff: f64, sig: &[f64]) -> Vec<f64> {
    let n = sig.len();
    if n < 4 || dt == 0.0 {
        return sig.to_vec();
    }
    let (a, b) = butterworth(dt, cutoff);
    let mut fwd = iir_pass(&a, &b, sig);
    fwd.reverse();
    let mut back = iir_pass(&a, &b, &fwd);
    back.reverse();
    back
}

/// `round53(round64(2·π₈₀·k))`: the double that C++ (x86-64 gcc, 80-bit
/// `long double`) stores for `2*SimTK_PI*k` when `SimTK_PI` is the long double
/// literal of π (simbody `SimTKcommon/Constants.h`) and `k` a double. For most
/// `k` this equals `2.0 * PI * k` in doubles, but not always (e.g. k = 7.5).
fn two_pi_long_double_times(k: f64) -> f64 {
    if !k.is_finite() || k == 0.0 {
        return 2.0 * std::f64::consts::PI * k;
    }
    // π rounded to a 64-bit significand: 0xC90FDAA22168C235 × 2⁻⁶².
    const PI64: u128 = 0xC90F_DAA2_2168_C235;
    let bits = k.abs().to_bits();
    let (exp_field, frac) = ((bits >> 52) as i32, bits & ((1u64 << 52) - 1));
    let (mant, exp) = if exp_field == 0 {
        (frac, -1074) // subnormal
    } else {
        (frac | (1u64 << 52), exp_field - 1075)
    };
    // Round a product to `keep` significant bits, half to even.
    fn round_bits(p: u128, keep: u32) -> (u128, i32) {
        let len = 128 - p.leading_zeros();
        if len <= keep {
            return (p, 0);
        }
        let sh = len - keep;
        let (mut q, rem, half) = (p >> sh, p & ((1u128 << sh) - 1), 1u128 << (sh - 1));
        if rem > half || (rem == half && q & 1 == 1) {
            q += 1;
        }
        (q, sh as i32)
    }
    let (q64, s1) = round_bits(PI64 * mant as u128, 64);
    let (q53, s2) = round_bits(q64, 53);
    // 2·π₈₀·k = q53 · 2^(s1 + s2 + exp − 62 + 1); q53 ≤ 2⁵³ is exact in f64.
    let v = q53 as f64 * 2f64.powi(s1 + s2 + exp - 61);
    v.copysign(k)
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

/// Read a coordinates file and, with a non-negative cutoff, pad it by half its
/// length and low-pass filter it as OpenSim's tools do (§9.2).
pub fn load_coordinates(path: &Path, lowpass_cutoff: f64) -> Result<Storage> {
    filter_coordinates(storage::read(path)?, path, lowpass_cutoff)
}

/// [`load_coordinates`] on a [`storage::TableFile`] (a run's motion, read
/// once).
pub fn load_coordinates_in(file: &storage::TableFile, lowpass_cutoff: f64) -> Result<Storage> {
    filter_coordinates(storage::read_file(file)?, file.path(), lowpass_cutoff)
}

/// [`load_coordinates`] on a table already read from `path`.
pub fn filter_coordinates(mut table: Storage, path: &Path, lowpass_cutoff: f64) -> Result<Storage> {
    if lowpass_cutoff >= 0.0 {
        let n = table.time.len() / 2;
        pad(&mut table, n);
        lowpass_iir(&mut table, lowpass_cutoff)
            .map_err(|e| e.context(format!("filtering {}", path.display())))?;
    }
    Ok(table)
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

    #[test]
    fn pole_radius_closed_form() {
        for (dt, fc) in [(0.01, 6.0), (0.001, 6.0), (0.0001, 6.0), (0.01, 40.0)] {
            let (_, b) = butterworth(dt, fc);
            let fs: f64 = 1.0 / dt;
            let fc = if fc >= 0.5 * fs { 0.49 * fs } else { fc };
            let wa = (std::f64::consts::PI * fc * dt).tan();
            let real = ((1.0 - wa) / (1.0 + wa)).abs();
            let pair = ((wa * wa - wa + 1.0) / (wa * wa + wa + 1.0)).sqrt();
            let want = real.max(pair);
            let got = pole_radius(&b);
            assert!((got - want).abs() < 1e-9, "dt {dt}: {got} vs {want}");
            // the impulse response decays at that rate
            let mut x = vec![0.0; 4000];
            x[3] = 1.0;
            let (a, b) = butterworth(dt, fc);
            let y = iir_pass(&a, &b, &x);
            let k = 1500;
            assert!(y[3 + k].abs() <= 10.0 * got.powi(k as i32) + 1e-300);
        }
    }

    #[test]
    fn long_double_two_pi() {
        // Expected values: exact rational arithmetic in Python (fractions):
        // round53(round64(2 * round64(pi) * k)), i.e. what x86-64 gcc computes
        // for 2*SimTK_PI*k with SimTK_PI a long double literal.
        assert_eq!(two_pi_long_double_times(6.0), 37.69911184307752);
        assert_eq!(two_pi_long_double_times(7.5), 47.1238898038469);
        assert_ne!(2.0 * std::f64::consts::PI * 7.5, 47.1238898038469);
        assert_eq!(two_pi_long_double_times(-3.0), -18.84955592153876);
    }

    fn find<'a>(el: &'a crate::xml::Element, name: &str) -> Option<&'a crate::xml::Element> {
        if el.name == name {
            return Some(el);
        }
        el.children.iter().find_map(|c| find(c, name))
    }

    /// OpenSim 4.6's AnalyzeTool preprocessing of the coordinates file
    /// (pad by half the row count, then lowpassIIR at the setup's cutoff),
    /// compared with the q columns of `results/<case>_SO_kinematic_targets.sto`.
    /// That file holds, for the frames StaticOptimization analysed (rows
    /// i0..i1 of the padded, resampled, filtered states storage), the q
    /// of every independent coordinate in radians/metres, after assembly.
    /// The coordinates files are in degrees; OpenSim converts the Rotational
    /// coordinates only. In these three models the translational coordinates
    /// are exactly those whose names end in `_tx`, `_ty`, `_tz`
    /// (pelvis_tx, pelvis_ty), so those columns are not converted.
    #[test]
    fn matches_opensim_kinematic_targets() {
        let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/validation");
        if !root.is_dir() {
            println!("SKIP: {} absent", root.display());
            return;
        }
        // leg6dof9musc has a CoordinateCouplerConstraint (knee_angle_pat_r),
        // so AnalyzeTool assembles each frame with the AssemblySolver, which
        // moves the tracked q away from the filtered values (by up to
        // 4.6e-5 rad in knee_angle_r, 1.7e-4 of its range). Its q are
        // therefore only checked loosely here; the filter itself is checked
        // for that case against OpenSim's pre-assembly output in
        // `matches_opensim_storage_filter_leg69`.
        for (case, prefix, tol) in [
            ("arm26", "arm26", 1e-9),
            ("leg6dof9musc_stance", "leg6dof9musc", 1e-3),
            ("gait10dof18musc_walk", "gait10dof18musc_walk", 1e-9),
        ] {
            let dir = root.join(case);
            let setup = crate::xml::parse_file(&dir.join("setup_SO.xml")).unwrap();
            let coords = find(&setup, "coordinates_file")
                .unwrap()
                .text()
                .trim()
                .to_string();
            let cutoff = find(&setup, "lowpass_cutoff_frequency_for_coordinates")
                .unwrap()
                .f64()
                .unwrap();
            assert_eq!(cutoff, 6.0);
            let mut table = crate::storage::read(&dir.join(&coords)).unwrap();
            assert!(table.in_degrees);
            let n = table.time.len() / 2;
            pad(&mut table, n);
            lowpass_iir(&mut table, cutoff).unwrap();

            let reference = crate::storage::read(
                &dir.join(format!("results/{prefix}_SO_kinematic_targets.sto")),
            )
            .unwrap();
            // Times: the reference rows are consecutive rows of our table.
            // The reference time column went through OpenSim's `%.20f`
            // output (e.g. -0.00000020000000500175 re-read and printed as
            // -2.0000000500175001e-07), so times are compared as C `%.20f`
            // strings: equal to 1e-20 absolute, bitwise for |t| >= 1e-4.
            let s20 = |t: f64| crate::storage::format_c_fixed(t, 0, 20);
            let i0 = table
                .time
                .iter()
                .position(|&t| s20(t) == s20(reference.time[0]))
                .unwrap_or_else(|| {
                    panic!("{case}: first time {} not in our grid", reference.time[0])
                });
            let nref = reference.time.len();
            assert!(i0 + nref <= table.time.len(), "{case}");
            let mut bitwise = 0;
            for (k, &t) in reference.time.iter().enumerate() {
                assert_eq!(s20(table.time[i0 + k]), s20(t), "{case} row {k}");
                bitwise += (table.time[i0 + k] == t) as usize;
            }
            let mut worst = (String::new(), 0.0f64, 0.0f64);
            let mut ncols = 0;
            for (jr, label) in reference.labels.iter().enumerate() {
                let Some(coord) = label.strip_suffix("_q") else {
                    continue;
                };
                ncols += 1;
                let j = table
                    .column_index(coord)
                    .unwrap_or_else(|| panic!("{case}: no column {coord}"));
                let translational = ["_tx", "_ty", "_tz"].iter().any(|s| coord.ends_with(s));
                let scale = if translational {
                    1.0
                } else {
                    std::f64::consts::PI / 180.0
                };
                let want = reference.column(jr);
                let range = want.iter().cloned().fold(f64::NEG_INFINITY, f64::max)
                    - want.iter().cloned().fold(f64::INFINITY, f64::min);
                let range = if range > 0.0 { range } else { 1.0 };
                let mut max_abs = 0.0f64;
                for (k, w) in want.iter().enumerate() {
                    let got = table.rows[i0 + k][j] * scale;
                    max_abs = max_abs.max((got - w).abs());
                }
                let rel = max_abs / range;
                if rel >= worst.2 {
                    worst = (coord.to_string(), max_abs, rel);
                }
                assert!(
                    rel <= tol,
                    "{case} {coord}: max |dq| {max_abs:e}, {rel:e} of range (tolerance {tol:e})"
                );
            }
            assert!(ncols > 0);
            println!(
                "{case}: {nref} rows (first at our row {i0}), times equal as %.20f ({bitwise} bitwise), {ncols} q columns; worst {} max |dq| {:.3e} ({:.3e} of range)",
                worst.0, worst.1, worst.2
            );
        }
    }

    /// The whole leg69_IK_stance.mot (131 columns, 91 rows, non-uniform
    /// times) padded and filtered, compared with OpenSim 4.6's own
    /// `Storage::pad` + `Storage::lowpassIIR` output (a row/column subset in
    /// testdata/, made with the venv call recorded in its header).
    #[test]
    fn matches_opensim_storage_filter_leg69() {
        let here = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
        let input =
            here.join("../shared/validation/leg6dof9musc_stance/inputs/leg69_IK_stance.mot");
        if !input.is_file() {
            println!("SKIP: {} absent", input.display());
            return;
        }
        let mut table = crate::storage::read(&input).unwrap();
        let n = table.time.len() / 2;
        pad(&mut table, n);
        lowpass_iir(&mut table, 6.0).unwrap();
        // OpenSim: s.getSize() == 188, first time -0.75, last 2.241999999999999
        assert_eq!(table.time.len(), 188);
        let reference = crate::storage::read(
            &here.join("src/motion/testdata/leg69_IK_stance_filtered_opensim46.sto"),
        )
        .unwrap();
        assert_eq!(reference.len(), 71);
        let s20 = |t: f64| crate::storage::format_c_fixed(t, 0, 20);
        let mut i = 0;
        let mut worst = (String::new(), 0.0f64);
        for (k, &t) in reference.time.iter().enumerate() {
            while i < table.time.len() && s20(table.time[i]) != s20(t) {
                i += 1;
            }
            assert!(
                i < table.time.len(),
                "reference time {t} (row {k}) not in our grid"
            );
            for (jr, label) in reference.labels.iter().enumerate() {
                let j = table.column_index(label).unwrap();
                let col = reference.column(jr);
                let range = col.iter().cloned().fold(f64::NEG_INFINITY, f64::max)
                    - col.iter().cloned().fold(f64::INFINITY, f64::min);
                let rel = (table.rows[i][j] - reference.rows[k][jr]).abs() / range;
                assert!(
                    rel <= 1e-9,
                    "{label} at t={t}: {} vs {}",
                    table.rows[i][j],
                    reference.rows[k][jr]
                );
                if rel > worst.1 {
                    worst = (label.clone(), rel);
                }
            }
        }
        println!(
            "leg69 filter vs OpenSim 4.6: 71 rows, times equal as %.20f; worst {} {:.3e} of range",
            worst.0, worst.1
        );
    }

    #[test]
    fn pad_larger_than_signal_matches_opensim() {
        // Reference: OpenSim 4.6 venv, Storage of time [0, 0.1, 0.25, 0.3],
        // y [1, 2, 4, 7]; s.pad(5) and s.pad(9), then getTimeColumn /
        // getDataColumn (values printed by Python's repr, so bitwise).
        let mut st = Storage {
            labels: vec!["y".into()],
            time: vec![0.0, 0.1, 0.25, 0.3],
            rows: vec![vec![1.0], vec![2.0], vec![4.0], vec![7.0]],
            ..Default::default()
        };
        let orig = st.clone();
        pad(&mut st, 5);
        assert_eq!(
            st.time,
            [-0.5, -0.35, -0.3, -0.25, -0.1, 0.0, 0.1, 0.25, 0.3, 0.35, 0.5, 0.6, 0.7, 0.85]
        );
        assert_eq!(
            st.column(0),
            [-10.0, -8.0, -5.0, -2.0, 0.0, 1.0, 2.0, 4.0, 7.0, 10.0, 12.0, 13.0, 14.0, 16.0]
        );
        let mut st = orig;
        pad(&mut st, 9);
        assert_eq!(
            st.column(0),
            [
                -17.0, -14.0, -12.0, -11.0, -10.0, -8.0, -5.0, -2.0, 0.0, 1.0, 2.0, 4.0, 7.0, 10.0,
                12.0, 13.0, 14.0, 16.0, 19.0, 22.0, 24.0, 25.0
            ]
        );
    }
}
