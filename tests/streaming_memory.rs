//! Static optimization streams its states (`motion::stream`): peak memory
//! does not grow with the length of the trial, and the streamed results equal
//! those of the in-memory states. A run reads its motion once and holds the
//! file's bytes (`storage::TableFile`, up to `storage::IN_MEMORY_LIMIT`):
//! peak memory grows by the motion file's size, and by nothing else.

mod common;

use std::path::{Path, PathBuf};
use std::process::Command;

use statopt::motion::states::States;
use statopt::parse::setup::Setup;
use statopt::storage;
use statopt::tools::{analyze, loading, RunOptions};

const G: f64 = 9.80665;

/// The block with no contact: static optimization's solution is
/// a = m (ẍ + g e_y) / 100 exactly.
fn model() -> String {
    common::block_model("")
}

/// The block's motion: `rows` rows 0.01 s apart, tx and ty moving.
fn motion_text(rows: usize) -> String {
    let mut s = format!(
        "block\nversion=1\nnRows={rows}\nnColumns=4\ninDegrees=no\nendheader\ntime\ttx\tty\ttz\n"
    );
    for k in 0..rows {
        let t = k as f64 * 0.01;
        s.push_str(&format!(
            "{t:.6}\t{:.12}\t{:.12}\t0\n",
            0.2 * (t * 0.5).sin(),
            0.01 * (t * 3.0).sin()
        ));
    }
    s
}

fn write_case(name: &str, rows: usize, cutoff: f64) -> PathBuf {
    let dir = common::out_dir(name);
    std::fs::write(dir.join("block.osim"), model()).unwrap();
    let s = motion_text(rows);
    std::fs::write(dir.join("motion.mot"), s).unwrap();
    let setup = format!(
        r#"<OpenSimDocument Version="40000"><AnalyzeTool name="block"><model_file>block.osim</model_file><results_directory>out</results_directory>
<initial_time>0</initial_time><final_time>100000</final_time><output_precision>14</output_precision>
<lowpass_cutoff_frequency_for_coordinates>{cutoff}</lowpass_cutoff_frequency_for_coordinates>
<AnalysisSet name="Analyses"><objects><StaticOptimization name="SO"/></objects></AnalysisSet>
<coordinates_file>motion.mot</coordinates_file></AnalyzeTool></OpenSimDocument>"#
    );
    std::fs::write(dir.join("setup.xml"), setup).unwrap();
    dir.join("setup.xml")
}

/// Size of `file` in MiB.
fn file_mib(file: &Path) -> f64 {
    std::fs::metadata(file).unwrap().len() as f64 / (1024.0 * 1024.0)
}

/// Size in MiB of the motion `bench --tile n` runs: the setup's motion
/// written `n` times over, time shifted, as `tools::bench` writes it.
fn tiled_mib(motion: &Path, n: usize) -> f64 {
    let t = storage::read(motion).unwrap();
    let len = t.time.len();
    let period = t.time[len - 1] - t.time[0] + (t.time[len - 1] - t.time[len - 2]);
    let path = motion.with_extension("tiled.sto");
    let mut w =
        storage::StoWriter::create(&path, &t.name, "", &t.labels, 10, t.in_degrees).unwrap();
    for k in 0..n {
        for i in 0..len {
            w.write_row(t.time[i] + k as f64 * period, &t.rows[i])
                .unwrap();
        }
    }
    w.finish().unwrap();
    let mib = file_mib(&path);
    std::fs::remove_file(&path).unwrap();
    mib
}

/// `statopt-tool bench` in a child process: (frames, peak MiB).
fn bench(setup: &Path, args: &[&str]) -> (usize, f64) {
    let out = Command::new(env!("CARGO_BIN_EXE_statopt-tool"))
        .arg("bench")
        .arg(setup)
        .args(["--threads", "1", "--repeat", "1"])
        .args(args)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "bench {args:?} failed: {stdout}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let mut lines = stdout.lines();
    let head: Vec<&str> = lines.next().unwrap().split('\t').collect();
    let row: Vec<&str> = lines.next().unwrap().split('\t').collect();
    let col = |name: &str| row[head.iter().position(|h| *h == name).unwrap()];
    (
        col("frames").parse().unwrap(),
        col("peak_MiB").parse().unwrap(),
    )
}

/// 1,000 frames and 100,000 frames (the motion tiled 100 times) in about the
/// same memory, apart from the motion's bytes (held once: 7.2 MiB at 100,000
/// rows). Before streaming, the states of the whole trial were held: on
/// arm26, 5.4 MiB at 1k frames grew to 77 MiB at 50k frames.
#[test]
fn peak_memory_does_not_grow_with_trial_length() {
    let setup = write_case("streaming_memory", 1000, -1.0);
    let (f1, m1) = bench(&setup, &["--tile", "1"]);
    let (f100, m100) = bench(&setup, &["--tile", "100"]);
    assert_eq!((f1, f100), (1000, 100_000));
    // Filtered: the 100,000 rows are padded to 200,000 and resampled at
    // OpenSim's cap of 100,000 steps; the frames from 0 to the padded end.
    let (g100, n100) = bench(&setup, &["--tile", "100", "--lowpass", "6"]);
    assert_eq!(g100, 50_000);
    println!(
        "peak memory: {f1} frames {m1:.1} MiB, {f100} frames {m100:.1} MiB, {g100} filtered frames {n100:.1} MiB"
    );
    // Holding the whole trial (the in-memory path) takes several times more:
    // about 1 KiB per row. The motion's bytes, read once, are the run's.
    let bytes = tiled_mib(&setup.parent().unwrap().join("motion.mot"), 100);
    println!("the tiled motion: {bytes:.1} MiB");
    assert!(
        m100 - bytes <= 2.0 * m1 && n100 - bytes <= 2.0 * m1,
        "peak memory grew with trial length beyond the motion's {bytes:.1} MiB: {m1} MiB at {f1} frames, {m100} MiB at {f100}, {n100} MiB filtered"
    );
}

/// Streamed static optimization on a motion long enough for many windows
/// (30,000 rows, padded to 60,000, filtered) against the in-memory states:
/// the activations are the closed-form m (ẍ + g e_y) / F₀ with ẍ the
/// in-memory path's target accelerations.
#[test]
fn streamed_results_equal_the_in_memory_states() {
    let setup_path = write_case("streaming_equal", 30_000, 6.0);
    let Setup::Analyze(setup) = Setup::read(&setup_path).unwrap() else {
        unreachable!()
    };
    analyze::run(
        &setup,
        &RunOptions {
            threads: Some(1),
            ..Default::default()
        },
    )
    .unwrap();
    let act = storage::read(
        &setup_path
            .parent()
            .unwrap()
            .join("out/block_SO_activation.sto"),
    )
    .unwrap();
    let (_, model) = loading::load_model(&setup.model_file).unwrap();
    let file = setup.coordinates_file.clone().unwrap();
    let table = loading::load_coordinates(&file, 6.0).unwrap();
    let states = States::from_coordinates(&model, &table, &file).unwrap();
    let udot = states.speed_derivatives(&file).unwrap();
    let rows = analyze::frame_rows(&states.time, setup.initial_time, setup.final_time, 1);
    assert_eq!(act.time.len(), rows.len());
    let (push, lift) = (
        act.column_index("push").unwrap(),
        act.column_index("lift").unwrap(),
    );
    let mut worst = 0.0f64;
    for (k, &i) in rows.iter().enumerate() {
        assert!((act.time[k] - states.time[i]).abs() < 1e-12);
        let want_push = 10.0 * udot[i][0] / 100.0;
        let want_lift = 10.0 * (udot[i][1] + G) / 100.0;
        worst = worst
            .max((act.rows[k][push] - want_push).abs())
            .max((act.rows[k][lift] - want_lift).abs());
    }
    println!(
        "{} streamed frames: activations within {worst:.2e} of the in-memory states' closed form",
        rows.len()
    );
    // 14 decimals written; the solver's own tolerance dominates.
    assert!(worst < 1e-9, "{worst}");
}

/// The InverseDynamicsTool's states streamed (`StatesKind::InverseDynamics`,
/// windows of 64 rows, so hundreds of windows) against one quintic spline
/// per coordinate through the whole (filtered) table (`CoordinateSplines`,
/// what the tool computed in memory before): q = S, u = S′, u̇ = S″ at every
/// row, equal to rounding (measured: 0 unfiltered, 6e-12 relative in u̇
/// filtered); an unfiltered motion in one window bit for bit.
#[test]
fn inverse_dynamics_states_streamed_equal_the_whole_table_splines() {
    use statopt::motion::coordinates::{CoordinateSplines, MissingCoordinate};
    use statopt::motion::stream::{StateStream, StatesKind};
    let setup_path = write_case("streaming_id", 3000, -1.0);
    let Setup::Analyze(setup) = Setup::read(&setup_path).unwrap() else {
        unreachable!()
    };
    let (_, model) = loading::load_model(&setup.model_file).unwrap();
    let file = setup.coordinates_file.clone().unwrap();
    for (cutoff, block) in [(-1.0, 64), (6.0, 64), (-1.0, 4096), (6.0, 1 << 20)] {
        let table = loading::load_coordinates(&file, cutoff).unwrap();
        let whole =
            CoordinateSplines::new(&model, &table, MissingCoordinate::DefaultValue, &file).unwrap();
        let mut stream = StateStream::open_with_block(&model, &file, cutoff, 0.0, 1e9, block)
            .unwrap()
            .for_inverse_dynamics();
        assert_eq!(stream.kind(), StatesKind::InverseDynamics);
        assert_eq!(stream.rows, whole.time.len());
        // The frames from findIndex(0) (a filtered table's padding before it).
        let from = statopt::motion::coordinates::find_index(&whole.time, 0.0);
        assert_eq!(
            (stream.first_row, stream.last_row),
            (from, whole.time.len() - 1)
        );
        let nq = model.nq();
        let (mut q, mut u, mut udot) = (vec![0.0; nq], vec![0.0; nq], vec![0.0; nq]);
        let (mut worst, mut rows, mut bitwise) = ([0.0f64; 3], 0, true);
        while let Some(b) = stream.next_block().unwrap() {
            for k in 0..b.time.len() {
                let i = b.first + k;
                assert_eq!(b.time[k], whole.time[i]);
                whole.eval(b.time[k], &mut q, &mut u, &mut udot);
                for c in 0..nq {
                    for (w, (got, want)) in worst.iter_mut().zip([
                        (b.q[k][c], q[c]),
                        (b.u[k][c], u[c]),
                        (b.udot[k][c], udot[c]),
                    ]) {
                        *w = w.max((got - want).abs() / (1.0 + want.abs()));
                        assert!(got.is_finite(), "row {i}, coordinate {c}: {got}");
                        bitwise &= got == want; // (±0 alike)
                    }
                }
                rows += 1;
            }
        }
        assert_eq!(rows, whole.time.len() - from);
        println!(
            "cutoff {cutoff}, block {block}: q, u, u̇ within {:.1e} / {:.1e} / {:.1e} (relative)",
            worst[0], worst[1], worst[2]
        );
        assert!(worst.iter().all(|&w| w < 1e-9), "{worst:?}");
        if block >= whole.time.len() && cutoff < 0.0 {
            // (A filtered window starts where the filter's memory has
            // faded, not at the padding's first row: equal to rounding.)
            assert!(
                bitwise,
                "one window: not the bits of the whole-table splines"
            );
        }
    }
}

/// Peak resident memory (VmHWM, MiB) of `statopt-tool -q SETUP`, read from
/// /proc while it runs (the last reading before it exits).
#[cfg(target_os = "linux")]
fn cli_peak_mib(setup: &Path) -> f64 {
    let mut child = Command::new(env!("CARGO_BIN_EXE_statopt-tool"))
        .arg("-q")
        .arg(setup)
        .spawn()
        .unwrap();
    let status = format!("/proc/{}/status", child.id());
    let mut peak = 0.0f64;
    loop {
        if let Ok(s) = std::fs::read_to_string(&status) {
            if let Some(kb) = s
                .lines()
                .find(|l| l.starts_with("VmHWM:"))
                .and_then(|l| l.split_whitespace().nth(1))
                .and_then(|v| v.parse::<f64>().ok())
            {
                peak = peak.max(kb / 1024.0);
            }
        }
        if let Some(st) = child.try_wait().unwrap() {
            assert!(st.success(), "{}", setup.display());
            return peak;
        }
        std::thread::sleep(std::time::Duration::from_millis(2));
    }
}

/// The InverseDynamicsTool streams its states too: its peak memory does not
/// grow with the trial, apart from the motion's bytes (held once, 4.2 MiB at
/// 100,000 rows). Before, it held the table and one spline per coordinate:
/// 7 MiB at 1,000 rows grew to 102 MiB at 100,000 (152 MiB filtered).
#[cfg(target_os = "linux")]
#[test]
fn inverse_dynamics_peak_memory_does_not_grow_with_trial_length() {
    let dir = common::out_dir("streaming_memory_id");
    std::fs::write(dir.join("block.osim"), model()).unwrap();
    let mut peaks = Vec::new();
    for (rows, cutoff) in [(1000usize, -1.0), (100_000, -1.0), (100_000, 6.0)] {
        let s = motion_text(rows);
        let motion = format!("motion_{rows}.mot");
        std::fs::write(dir.join(&motion), s).unwrap();
        let setup = dir.join(format!("id_{rows}_{cutoff}.xml"));
        std::fs::write(
            &setup,
            format!(
                r#"<OpenSimDocument Version="40000"><InverseDynamicsTool name="id"><model_file>block.osim</model_file><coordinates_file>{motion}</coordinates_file><lowpass_cutoff_frequency_for_coordinates>{cutoff}</lowpass_cutoff_frequency_for_coordinates><time_range>0 1e9</time_range><results_directory>out</results_directory><output_gen_force_file>id_{rows}_{cutoff}.sto</output_gen_force_file></InverseDynamicsTool></OpenSimDocument>"#
            ),
        )
        .unwrap();
        let peak = cli_peak_mib(&setup);
        let written = storage::read(&dir.join(format!("out/id_{rows}_{cutoff}.sto"))).unwrap();
        // (Filtered, the padded table is resampled at OpenSim's cap of
        // 100,000 steps and its rows past the data are in the time range:
        // 75,001 rows, as before streaming.)
        let want = if cutoff < 0.0 { rows } else { 75_001 };
        assert_eq!(written.time.len(), want);
        peaks.push(peak);
    }
    println!(
        "InverseDynamicsTool peak memory: 1k rows {:.1} MiB, 100k rows {:.1} MiB, 100k filtered {:.1} MiB",
        peaks[0], peaks[1], peaks[2]
    );
    let bytes = file_mib(&dir.join("motion_100000.mot"));
    assert!(
        peaks[1] - bytes <= 2.0 * peaks[0] && peaks[2] - bytes <= 2.0 * peaks[0],
        "peak memory grew with trial length beyond the motion's {bytes:.1} MiB: {peaks:?} MiB"
    );
}

/// External loads from a long data file are splined window by window
/// (`forces::external_loads`): the InverseDynamicsTool with ground
/// reactions as long as its motion keeps a flat peak memory. Before, every
/// column was splined through the whole file, read whole: 100,000 rows of
/// nine columns took the run from 8.0 to 64.6 MiB (about 20 MiB now, 4.2 MiB
/// of it the motion's bytes, read once).
#[cfg(target_os = "linux")]
#[test]
fn external_loads_peak_memory_does_not_grow_with_trial_length() {
    let dir = common::out_dir("streaming_memory_grf");
    std::fs::write(dir.join("block.osim"), model()).unwrap();
    let mut peaks = Vec::new();
    for rows in [1000usize, 100_000] {
        std::fs::write(dir.join(format!("motion_{rows}.mot")), motion_text(rows)).unwrap();
        let mut grf = format!(
            "grf\nversion=1\nnRows={rows}\nnColumns=10\ninDegrees=no\nendheader\n\
             time\tf_vx\tf_vy\tf_vz\tf_px\tf_py\tf_pz\tt_x\tt_y\tt_z\n"
        );
        for k in 0..rows {
            let t = k as f64 * 0.01;
            let s = (t * 2.0).sin();
            grf.push_str(&format!(
                "{t:.6}\t{:.9}\t{:.9}\t0\t{:.9}\t0\t0\t0\t0\t{:.9}\n",
                5.0 * s,
                98.0 + 10.0 * s,
                0.01 * s,
                0.1 * s
            ));
        }
        std::fs::write(dir.join(format!("grf_{rows}.mot")), grf).unwrap();
        std::fs::write(
            dir.join(format!("grf_{rows}.xml")),
            format!(
                r#"<OpenSimDocument Version="40000"><ExternalLoads name="grf"><objects><ExternalForce name="f"><applied_to_body>block</applied_to_body><force_expressed_in_body>ground</force_expressed_in_body><point_expressed_in_body>ground</point_expressed_in_body><force_identifier>f_v</force_identifier><point_identifier>f_p</point_identifier><torque_identifier>t_</torque_identifier></ExternalForce></objects><datafile>grf_{rows}.mot</datafile></ExternalLoads></OpenSimDocument>"#
            ),
        )
        .unwrap();
        let setup = dir.join(format!("id_{rows}.xml"));
        std::fs::write(
            &setup,
            format!(
                r#"<OpenSimDocument Version="40000"><InverseDynamicsTool name="id"><model_file>block.osim</model_file><coordinates_file>motion_{rows}.mot</coordinates_file><external_loads_file>grf_{rows}.xml</external_loads_file><time_range>0 1e9</time_range><results_directory>out</results_directory><output_gen_force_file>id_{rows}.sto</output_gen_force_file></InverseDynamicsTool></OpenSimDocument>"#
            ),
        )
        .unwrap();
        peaks.push(cli_peak_mib(&setup));
        let written = storage::read(&dir.join(format!("out/id_{rows}.sto"))).unwrap();
        assert_eq!(written.time.len(), rows);
        // The loads are applied: ty's generalized force is
        // m (ÿ + g) − F_y with ty = 0.01 sin 3t and F_y = 98 + 10 sin 2t.
        let ty = written.column_index("ty_force").expect("ty_force");
        for k in [rows / 3, rows / 2, rows - rows / 7] {
            let t = written.time[k];
            let want = 10.0 * (-0.09 * (3.0 * t).sin() + G) - (98.0 + 10.0 * (2.0 * t).sin());
            let got = written.rows[k][ty];
            assert!(
                (got - want).abs() < 1e-3,
                "t {t}: ty force {got}, want {want}"
            );
        }
    }
    println!(
        "InverseDynamicsTool with external loads, peak memory: 1k rows {:.1} MiB, 100k rows {:.1} MiB",
        peaks[0], peaks[1]
    );
    // The motion's bytes are held once; the loads are streamed from the disk.
    let bytes = file_mib(&dir.join("motion_100000.mot"));
    assert!(
        peaks[1] - bytes <= 2.0 * peaks[0],
        "peak memory grew with trial length beyond the motion's {bytes:.1} MiB: {peaks:?} MiB"
    );
}
