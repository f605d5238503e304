//! The seated leg press study runs as shipped (setups/leg_press_study.xml,
//! models/leg_press): every frame of every w0 is solved; the knee loads have
//! the closed-chain shape Escamilla et al. (1998) measured (tibiofemoral
//! compression highest near full flexion, shear PCL-type in flexion); every
//! contact that carries load is static and does not sink into its surface;
//! the study draws its figures and metrics; and the shipped motion is what
//! the recorded statopt-tool command writes.

use std::path::PathBuf;

use statopt::plan::StudyPlan;
use statopt::storage;
use statopt::tools::{study, RunOptions};

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn col(t: &storage::Storage, c: &str) -> Vec<f64> {
    t.column(t.column_index(c).unwrap_or_else(|| panic!("no column {c}")))
}

/// Run the study into a fresh folder; the setup's tables land in
/// `<out>/leg_press_rajagopal/`.
fn run_study(tag: &str) -> PathBuf {
    let out = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(tag);
    let _ = std::fs::remove_dir_all(&out);
    let setup = root().join("setups/leg_press_study.xml");
    assert!(statopt::plan::is_study(&setup));
    study::run(
        &StudyPlan::read(&setup, false).unwrap(),
        &RunOptions {
            results_dir: Some(out.clone()),
            ..Default::default()
        },
    )
    .unwrap_or_else(|e| panic!("the leg press study failed: {e}"));
    out
}

const W0: [&str; 3] = ["1", "500", "1000"];

#[test]
fn leg_press_study_meets_its_acceptance() {
    let out = run_study("leg_press_study");
    let table = |k: &str| {
        let p = out
            .join("leg_press_rajagopal")
            .join(format!("leg_press_rajagopal_{k}.sto"));
        storage::read(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
    };
    for w0 in W0 {
        // Every frame solved, the equations of motion met.
        let diag = table(&format!("SO_w0_{w0}_diagnostics"));
        assert_eq!(diag.time.len(), 91, "w0 {w0}: frames");
        let status = col(&diag, "status");
        let residual = col(&diag, "relative_residual");
        for i in 0..diag.time.len() {
            assert_eq!(status[i], 0.0, "w0 {w0} t={}: not solved", diag.time[i]);
            assert!(
                residual[i] < 1e-6,
                "w0 {w0} t={}: residual {}",
                diag.time[i],
                residual[i]
            );
        }

        // Knee compression peaks within 20 deg of the deepest flexion.
        let knee = table(&format!("JR_w0_{w0}_KneeLoads"));
        let flexion = col(&knee, "knee_flexion_r");
        let compression = col(&knee, "tf_compression_r");
        let shear = col(&knee, "tf_shear_r");
        let deepest = flexion.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
        assert!(deepest > 90.0, "w0 {w0}: deepest flexion {deepest}");
        let peak = (0..compression.len())
            .max_by(|&a, &b| compression[a].total_cmp(&compression[b]))
            .unwrap();
        assert!(
            deepest - flexion[peak] <= 20.0,
            "w0 {w0}: compression peaks at {:.1} deg, deepest flexion {deepest:.1} deg",
            flexion[peak]
        );
        // Tibiofemoral shear PCL-type (positive) on at least 95 % of the
        // frames flexed 30 deg or more.
        let flexed: Vec<usize> = (0..flexion.len()).filter(|&i| flexion[i] >= 30.0).collect();
        assert!(
            flexed.len() > 30,
            "w0 {w0}: {} frames flexed >= 30 deg",
            flexed.len()
        );
        let pcl = flexed.iter().filter(|&&i| shear[i] > 0.0).count();
        assert!(
            pcl as f64 >= 0.95 * flexed.len() as f64,
            "w0 {w0}: shear PCL-type on {pcl} of {} frames flexed >= 30 deg",
            flexed.len()
        );

        // Every contact carrying more than 10 N is static and no deeper
        // than 1 mm into its plane, on every frame.
        let cf = table(&format!("SO_w0_{w0}_ContactForces"));
        let contacts: Vec<String> = cf
            .labels
            .iter()
            .filter_map(|l| l.strip_suffix("_regime").map(String::from))
            .collect();
        assert_eq!(contacts.len(), 16, "w0 {w0}: contacts {contacts:?}");
        let mut loaded = 0;
        for c in &contacts {
            let (fx, fy, fz) = (
                col(&cf, &format!("{c}_fx")),
                col(&cf, &format!("{c}_fy")),
                col(&cf, &format!("{c}_fz")),
            );
            let regime = col(&cf, &format!("{c}_regime"));
            let d = col(&cf, &format!("{c}_distance"));
            for i in 0..cf.time.len() {
                let f = (fx[i] * fx[i] + fy[i] * fy[i] + fz[i] * fz[i]).sqrt();
                if f > 10.0 {
                    loaded += 1;
                    assert_eq!(
                        regime[i], 0.0,
                        "w0 {w0} t={}: {c} carries {f:.1} N kinetic",
                        cf.time[i]
                    );
                    assert!(
                        d[i] >= -1e-3,
                        "w0 {w0} t={}: {c} carries {f:.1} N {:.4} m deep",
                        cf.time[i],
                        -d[i]
                    );
                }
            }
        }
        assert!(
            loaded > 91 * 6,
            "w0 {w0}: only {loaded} loaded contact frames"
        );

        // The plate pushes the feet back along the rail with at least the
        // stack's weight (0.5 BW = 369.4 N) at the slow ends of the press.
        let plate: Vec<f64> = (0..cf.time.len())
            .map(|i| {
                ["heel_r", "heel_l", "forefoot_r", "forefoot_l"]
                    .iter()
                    .map(|c| -col(&cf, &format!("{c}_fx"))[i])
                    .sum()
            })
            .collect();
        let stack = 0.5 * 75.337 * 9.80665;
        assert!(
            (plate[0] - stack).abs() < 0.01 * stack,
            "w0 {w0}: plate force {} at rest, stack {stack}",
            plate[0]
        );
    }
    for f in ["leg_press_knee_loads", "leg_press_contact_sharing"] {
        for ext in ["png", "svg"] {
            let p = out.join(format!("{f}.{ext}"));
            assert!(
                p.is_file() && std::fs::metadata(&p).unwrap().len() > 1000,
                "{}",
                p.display()
            );
        }
    }
    let metrics = std::fs::read_to_string(out.join("leg_press_metrics.csv")).unwrap();
    assert!(metrics
        .lines()
        .any(|l| l.starts_with("peak_tf_compression_flexion_deg,")));
}

/// The shipped motion is what models/leg_press/motion_command.sh writes with
/// statopt-tool: run that command (into a temporary file) and compare.
#[test]
fn shipped_motion_is_the_recorded_command_output() {
    let script =
        std::fs::read_to_string(root().join("models/leg_press/motion_command.sh")).unwrap();
    let joined = script
        .lines()
        .filter(|l| !l.trim_start().starts_with('#'))
        .collect::<Vec<_>>()
        .join("\n")
        .replace("\\\n", " ");
    let command = joined
        .lines()
        .find(|l| l.trim_start().starts_with("$STATOPT motion"))
        .expect("the script runs $STATOPT motion");
    let mut args: Vec<String> = command
        .split_whitespace()
        .skip(1)
        .map(String::from)
        .collect();
    let out = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("leg_press_motion.mot");
    let o = args.iter().position(|a| a == "-o").expect("-o");
    assert_eq!(args[o + 1], "motions/leg_press_rajagopal.mot");
    args[o + 1] = out.display().to_string();
    let status = std::process::Command::new(env!("CARGO_BIN_EXE_statopt-tool"))
        .args(&args)
        .current_dir(root())
        .status()
        .unwrap();
    assert!(status.success(), "statopt-tool {args:?}");
    let shipped = std::fs::read_to_string(root().join("motions/leg_press_rajagopal.mot")).unwrap();
    let made = std::fs::read_to_string(&out).unwrap();
    assert!(
        shipped == made,
        "motions/leg_press_rajagopal.mot differs from what its command writes"
    );
}
