//! Stability suite, kinematics (issue 8): the leg extension study
//! (setups/leg_extension_cam1.xml, one contact weight) with noisy
//! coordinates, and the knee driven to full extension.
//!
//! Noise: zero-mean Gaussian, standard deviation 0.1, 0.5, 1 and 2 degrees,
//! on every rotational coordinate of motions/leg_extension.mot (translations
//! are in metres and are left alone), from one seeded ChaCha stream scaled
//! by the level (common random numbers, so levels differ only in size).
//! To stay fast in debug builds every 5th of the 101 rows is solved
//! (`step_interval` 5: 21 frames); the filter sees every row.
//! Print the table with `cargo test --test stability_noise -- --nocapture`.

mod common;

use std::path::{Path, PathBuf};

use proptest::prelude::RngExt;
use proptest::test_runner::{RngAlgorithm, TestRng};
use statopt::parse::setup::Setup;
use statopt::storage::{self, Storage};
use statopt::tools::{analyze, RunOptions, RunSummary};

const LEVELS_DEG: [f64; 4] = [0.1, 0.5, 1.0, 2.0];
const CUTOFF_HZ: f64 = 6.0;
/// Without reserves even 0.1 deg of noise makes every frame infeasible (the
/// pelvis and lever accelerations the noise creates cannot be balanced by
/// the seat contacts and muscles): measured 21 of 21 failed frames at every
/// level. Reserves (1 N m per coordinate: expensive) keep the frames
/// solvable so that the errors compare optima, not elastic fallbacks.
const RESERVES: &str = "<reserve_actuators>1</reserve_actuators>";

fn repo(p: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join(p)
}

/// The study's cam-1 setup with absolute paths, one w0 (1000), no figures,
/// the given motion file, filter cutoff and step interval.
fn setup_text(motion: &Path, cutoff: f64, step: usize, results: &Path, reserves: &str) -> String {
    let s = std::fs::read_to_string(repo("setups/leg_extension_cam1.xml")).unwrap();
    let (a, b) = (
        s.find("<Figure").unwrap(),
        s.find("<external_loads_file").unwrap(),
    );
    let s = format!("{}{}", &s[..a], &s[b..]);
    s.replace("../models/", &format!("{}/", repo("models").display()))
        .replace(
            "<results_directory>../output/leg_extension_cam1</results_directory>",
            &format!("<results_directory>{}</results_directory>", results.display()),
        )
        .replace(
            "<contact_weight>1 500 1000</contact_weight>",
            &format!("<contact_weight>1000</contact_weight>{reserves}"),
        )
        .replace("<step_interval>1</step_interval>", &format!("<step_interval>{step}</step_interval>"))
        .replace(
            "<coordinates_file>../motions/leg_extension.mot</coordinates_file>",
            &format!("<coordinates_file>{}</coordinates_file>", motion.display()),
        )
        .replace(
            "<lowpass_cutoff_frequency_for_coordinates>-1</lowpass_cutoff_frequency_for_coordinates>",
            &format!("<lowpass_cutoff_frequency_for_coordinates>{cutoff}</lowpass_cutoff_frequency_for_coordinates>"),
        )
}

fn run(
    dir: &Path,
    name: &str,
    motion: &Path,
    cutoff: f64,
    step: usize,
    reserves: &str,
) -> (PathBuf, statopt::Result<RunSummary>) {
    let out = dir.join(name);
    let p = dir.join(format!("{name}.xml"));
    std::fs::write(&p, setup_text(motion, cutoff, step, &out, reserves)).unwrap();
    let s = match Setup::read(&p).unwrap() {
        Setup::Analyze(s) => s,
        _ => unreachable!(),
    };
    let r = analyze::run(&s, &RunOptions::default());
    (out, r)
}

fn read(dir: &Path, file: &str) -> Storage {
    storage::read(&dir.join(file)).unwrap_or_else(|e| panic!("{file}: {e}"))
}

/// Write `m` as a .mot in degrees, adding `noise[j][i]` to column j.
fn write_motion(path: &Path, m: &Storage, noise: &[Vec<f64>]) {
    let mut s = format!(
        "noisy motion\nversion=1\nnRows={}\nnColumns={}\ninDegrees=yes\nendheader\ntime\t{}\n",
        m.time.len(),
        m.labels.len() + 1,
        m.labels.join("\t")
    );
    for (i, t) in m.time.iter().enumerate() {
        s.push_str(&format!("{t:.8}"));
        for j in 0..m.labels.len() {
            s.push_str(&format!("\t{:.12}", m.rows[i][j] + noise[j][i]));
        }
        s.push('\n');
    }
    std::fs::write(path, s).unwrap();
}

/// Unit Gaussian noise per column and row (Box–Muller on the seeded
/// stream), zero for translations.
fn unit_noise(m: &Storage) -> Vec<Vec<f64>> {
    let mut rng = TestRng::from_seed(RngAlgorithm::ChaCha, &[7u8; 32]);
    m.labels
        .iter()
        .map(|l| {
            (0..m.time.len())
                .map(|_| {
                    let (u1, u2): (f64, f64) = (rng.random(), rng.random());
                    let z =
                        (-2.0 * (1.0 - u1).ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos();
                    if l.ends_with("_tx") || l.ends_with("_ty") || l.ends_with("_tz") {
                        0.0
                    } else {
                        z
                    }
                })
                .collect()
        })
        .collect()
}

const PREFIX: &str = "leg_extension_cam1";

/// RMS of the reserve controls (N m, optimal force 1) over all frames.
fn reserve_rms(a: &Storage) -> f64 {
    let (mut s, mut n) = (0.0, 0.0);
    for r in &a.rows {
        for (j, l) in a.labels.iter().enumerate() {
            if l.ends_with("_reserve") {
                s += r[j] * r[j];
                n += 1.0;
            }
        }
    }
    (s / n).sqrt()
}

/// (activations, knee_r reaction force columns, number of failed frames)
fn outputs(out: &Path) -> (Storage, [Vec<f64>; 3], usize) {
    let act = read(out, &format!("{PREFIX}_SO_activation.sto"));
    let jr = read(out, &format!("{PREFIX}_JR_ReactionLoads.sto"));
    let diag = read(out, &format!("{PREFIX}_SO_diagnostics.sto"));
    assert!(
        act.rows.iter().flatten().all(|v| v.is_finite()),
        "NaN activation"
    );
    assert!(
        jr.rows.iter().flatten().all(|v| v.is_finite()),
        "NaN reaction"
    );
    let c = |s: &str| {
        jr.column(
            jr.column_index(&format!("knee_r_on_tibia_r_in_tibia_r_{s}"))
                .unwrap(),
        )
    };
    let st = diag.column(diag.column_index("status").unwrap());
    (
        act,
        [c("fx"), c("fy"), c("fz")],
        st.iter().filter(|s| **s < 0.0).count(),
    )
}

/// RMS activation difference (all muscles, all frames; reserves left out) and RMS magnitude of
/// the knee reaction force difference (N).
fn errors(a: &(Storage, [Vec<f64>; 3], usize), b: &(Storage, [Vec<f64>; 3], usize)) -> (f64, f64) {
    let (mut sa, mut na) = (0.0, 0.0);
    let muscles: Vec<usize> = (0..a.0.labels.len())
        .filter(|&j| !a.0.labels[j].ends_with("_reserve"))
        .collect();
    for (ra, rb) in a.0.rows.iter().zip(&b.0.rows) {
        for &j in &muscles {
            sa += (ra[j] - rb[j]) * (ra[j] - rb[j]);
            na += 1.0;
        }
    }
    let n = a.1[0].len();
    let mut sf = 0.0;
    for i in 0..n {
        sf += (0..3).map(|k| (a.1[k][i] - b.1[k][i]).powi(2)).sum::<f64>();
    }
    ((sa / na).sqrt(), (sf / n as f64).sqrt())
}

/// Noise in → error out: the error against the noise-free run (same filter
/// setting) grows with the noise level, and the 6 Hz low-pass filter lowers
/// it at every level, for activations and for the knee reaction force. Every
/// run finishes with finite tables.
#[test]
fn noisy_kinematics_error_grows_with_noise_and_filtering_reduces_it() {
    let dir = common::out_dir("stability_noise");
    let clean = storage::read(&repo("motions/leg_extension.mot")).unwrap();
    let z = unit_noise(&clean);
    let clean_path = dir.join("clean.mot");
    write_motion(
        &clean_path,
        &clean,
        &vec![vec![0.0; clean.time.len()]; clean.labels.len()],
    );
    let mut base = Vec::new();
    for (tag, cutoff) in [("raw", -1.0), ("filtered", CUTOFF_HZ)] {
        let (out, r) = run(
            &dir,
            &format!("clean_{tag}"),
            &clean_path,
            cutoff,
            5,
            RESERVES,
        );
        r.unwrap_or_else(|e| panic!("clean {tag}: {e}"));
        let o = outputs(&out);
        assert_eq!(o.2, 0, "noise-free run ({tag}) has failed frames");
        base.push(o);
    }
    println!("noise (deg) | activation RMS error raw / filtered | knee_r force RMS error (N) raw / filtered | reserve RMS (N m) raw / filtered | failed frames raw / filtered (of 21)");
    println!(
        "  clean | reserve RMS (N m) raw {:.4} / filtered {:.4}",
        reserve_rms(&base[0].0),
        reserve_rms(&base[1].0)
    );
    let mut table = Vec::new();
    for level in LEVELS_DEG {
        let noise: Vec<Vec<f64>> = z
            .iter()
            .map(|c| c.iter().map(|v| v * level).collect())
            .collect();
        let p = dir.join(format!("noise_{level}.mot"));
        write_motion(&p, &clean, &noise);
        let mut row = Vec::new();
        for (k, (tag, cutoff)) in [("raw", -1.0), ("filtered", CUTOFF_HZ)]
            .into_iter()
            .enumerate()
        {
            let (out, r) = run(
                &dir,
                &format!("noise_{level}_{tag}"),
                &p,
                cutoff,
                5,
                RESERVES,
            );
            r.unwrap_or_else(|e| panic!("noise {level} {tag}: {e}"));
            let o = outputs(&out);
            let (ea, ef) = errors(&o, &base[k]);
            row.push((ea, ef, o.2, reserve_rms(&o.0)));
        }
        println!(
            "  {level:4} | {:.4} / {:.4} | {:.1} / {:.1} | {:.2} / {:.2} | {} / {}",
            row[0].0, row[1].0, row[0].1, row[1].1, row[0].3, row[1].3, row[0].2, row[1].2
        );
        table.push(row);
    }
    for (l, row) in LEVELS_DEG.iter().zip(&table) {
        // Unbounded reserves make every frame feasible, so every frame must
        // be solved (Clarabel once declared a raw 1 deg end frame with
        // 1.8 kN m to balance infeasible at iteration 3; optimize::solve now
        // re-checks such claims with a strict infeasibility tolerance).
        assert_eq!(
            (row[0].2, row[1].2),
            (0, 0),
            "{l} deg: frames failed (raw, filtered) although the reserves make them feasible"
        );
        assert!(
            row[1].0 < row[0].0,
            "{l} deg: filtering does not reduce the activation error"
        );
        assert!(
            row[1].1 < row[0].1,
            "{l} deg: filtering does not reduce the knee force error"
        );
    }
    // Activation errors grow strictly with the noise. The knee force error
    // is not strictly monotone (measured filtered: 441, 938, 890, 1382 N:
    // saturating muscles and the frames' own noise draws), so it is held to
    // exceed the 0.1 deg error at every level and to be largest at 2 deg.
    for k in 0..2 {
        for w in table.windows(2) {
            assert!(
                w[1][k].0 > w[0][k].0,
                "activation error does not grow with noise"
            );
        }
        for row in &table[1..] {
            assert!(
                row[k].1 > table[0][k].1,
                "knee force error below the 0.1 deg one"
            );
        }
        let last = table[table.len() - 1][k].1;
        assert!(
            table.iter().all(|r| r[k].1 <= last),
            "knee force error not largest at 2 deg"
        );
    }
}

/// The knee driven to full extension (0 deg, the end of its range is
/// 10 deg) and slightly beyond: the pad contact is closed at every pose, and
/// every frame gets a defined, finite answer with the equations of motion
/// and friction limits met where solved (or is reported).
#[test]
fn knee_at_full_extension_gives_a_defined_answer() {
    let dir = common::out_dir("stability_knee_extended");
    let m = storage::read(&repo("motions/leg_extension.mot")).unwrap();
    // Ramp both knees from -10 to +5 deg over the 5 s.
    let mut noise = vec![vec![0.0; m.time.len()]; m.labels.len()];
    let n = m.time.len();
    for side in ["knee_angle_r", "knee_angle_l"] {
        let j = m.column_index(side).unwrap();
        for i in 0..n {
            let target = -10.0 + 15.0 * i as f64 / (n - 1) as f64;
            noise[j][i] = target - m.rows[i][j];
        }
    }
    let p = dir.join("extended.mot");
    write_motion(&p, &m, &noise);
    let (out, r) = run(&dir, "extended", &p, -1.0, 5, "");
    let s = r.unwrap_or_else(|e| panic!("full extension: {e}"));
    let diag = read(&out, &format!("{PREFIX}_SO_diagnostics.sto"));
    let (_, _, failed) = outputs(&out);
    let col = |l: &str| diag.column(diag.column_index(l).unwrap());
    let (st, rr, fv) = (
        col("status"),
        col("relative_residual"),
        col("friction_violation"),
    );
    for i in 0..diag.time.len() {
        if st[i] >= 0.0 {
            assert!(rr[i] < 1e-5, "t={}: EOM residual {}", diag.time[i], rr[i]);
            assert!(
                fv[i] < 1e-6,
                "t={}: friction violation {}",
                diag.time[i],
                fv[i]
            );
        }
    }
    if failed > 0 {
        assert!(
            s.warnings.iter().any(|w| w.contains("failed on")),
            "{:?}",
            s.warnings
        );
    }
    println!(
        "knee -10..+5 deg: {failed} of {} frames failed; warnings {:?}",
        diag.time.len(),
        s.warnings
    );
}
