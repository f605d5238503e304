//! Helpers shared by the integration tests.
#![allow(dead_code)]

use std::path::PathBuf;

pub mod contact_scene;

/// `../shared/validation` beside the repository, or None (with a clear SKIP
/// line) when it is absent.
pub fn validation_dir(test: &str) -> Option<PathBuf> {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../shared/validation");
    if dir.is_dir() {
        Some(dir)
    } else {
        eprintln!("SKIP {test}: ../shared/validation is absent, so the OpenSim reference comparison did not run");
        None
    }
}

pub const CASES: [&str; 3] = ["arm26", "leg6dof9musc_stance", "gait10dof18musc_walk"];

/// A fresh output directory for one test.
pub fn out_dir(name: &str) -> PathBuf {
    let d = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(name);
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Per-column comparison of two tables on their common time rows.
pub struct ColumnError {
    pub label: String,
    pub max_abs: f64,
    pub peak: f64,
    pub worst_time: f64,
}

/// Compare `ours` against `reference` column by column (matched by label),
/// row by row (rows must have equal times within 1e-9).
pub fn compare(
    ours: &statopt::storage::Storage,
    reference: &statopt::storage::Storage,
) -> Vec<ColumnError> {
    assert_eq!(
        ours.time.len(),
        reference.time.len(),
        "row counts differ: ours {} vs reference {}",
        ours.time.len(),
        reference.time.len()
    );
    for (a, b) in ours.time.iter().zip(&reference.time) {
        assert!((a - b).abs() < 1e-9, "time {a} vs reference {b}");
    }
    let mut out = Vec::new();
    for (j, label) in reference.labels.iter().enumerate() {
        let k = ours
            .column_index(label)
            .unwrap_or_else(|| panic!("our output lacks column '{label}'"));
        let mut e = ColumnError {
            label: label.clone(),
            max_abs: 0.0,
            peak: 0.0,
            worst_time: 0.0,
        };
        for i in 0..reference.time.len() {
            let (r, o) = (reference.rows[i][j], ours.rows[i][k]);
            e.peak = e.peak.max(r.abs());
            let d = (r - o).abs();
            if d > e.max_abs || d.is_nan() {
                e.max_abs = if d.is_nan() { f64::INFINITY } else { d };
                e.worst_time = reference.time[i];
            }
        }
        out.push(e);
    }
    out
}

/// Standard gravity, as in OpenSim's default model.
pub const G: f64 = 9.80665;

/// A 10 kg block on three slider coordinates (a CustomJoint with only
/// translations) with one point actuator (optimal force 100 N) along each
/// axis; `extra_forces` is appended to its ForceSet (e.g. a contact).
pub fn block_model(extra_forces: &str) -> String {
    let t = |name: &str, c: &str, ax: &str| {
        format!(
            r#"<TransformAxis name="{name}"><coordinates>{c}</coordinates><axis>{ax}</axis><LinearFunction name="function"><coefficients>1 0</coefficients></LinearFunction></TransformAxis>"#
        )
    };
    let r = |name: &str, ax: &str| {
        format!(r#"<TransformAxis name="{name}"><coordinates/><axis>{ax}</axis></TransformAxis>"#)
    };
    let act = |name: &str, d: &str| {
        format!(
            r#"<PointActuator name="{name}"><body>block</body><point>0 0 0</point><direction>{d}</direction><force_is_global>true</force_is_global><optimal_force>100</optimal_force><min_control>-Inf</min_control><max_control>Inf</max_control></PointActuator>"#
        )
    };
    format!(
        r#"<OpenSimDocument Version="40000"><Model name="block"><gravity>0 -{} 0</gravity>
<BodySet><objects><Body name="block"><mass>10</mass><mass_center>0 0.05 0</mass_center><inertia>0.1 0.1 0.1 0 0 0</inertia></Body></objects></BodySet>
<JointSet><objects><CustomJoint name="slide"><socket_parent_frame>/ground</socket_parent_frame><socket_child_frame>/bodyset/block</socket_child_frame>
<coordinates><Coordinate name="tx"><range>-1000 1000</range></Coordinate><Coordinate name="ty"><range>-1000 1000</range></Coordinate><Coordinate name="tz"/></coordinates>
<SpatialTransform>{}{}{}{}{}{}</SpatialTransform></CustomJoint></objects></JointSet>
<ForceSet><objects>{}{}{}{extra_forces}</objects></ForceSet></Model></OpenSimDocument>"#,
        G,
        r("rotation1", "1 0 0"),
        r("rotation2", "0 1 0"),
        r("rotation3", "0 0 1"),
        t("translation1", "tx", "1 0 0"),
        t("translation2", "ty", "0 1 0"),
        t("translation3", "tz", "0 0 1"),
        act("push", "1 0 0"),
        act("lift", "0 1 0"),
        act("side", "0 0 1")
    )
}

/// The setup, its StaticOptimization settings (the friction model replaced
/// when given) and the compiled problem.
pub fn so_case(
    setup_file: &std::path::Path,
    friction: Option<statopt::optimize::FrictionModel>,
) -> (
    statopt::parse::setup::AnalyzeSetup,
    statopt::tools::static_optimization::StaticOptimizationSetup,
    statopt::tools::static_optimization::SoProblem,
) {
    use statopt::parse::setup::Setup;
    use statopt::tools::static_optimization::{SoProblem, StaticOptimizationSetup};
    let setup = match Setup::read(setup_file).unwrap() {
        Setup::Analyze(s) => s,
        _ => unreachable!(),
    };
    let mut so: StaticOptimizationSetup = setup.static_optimization().unwrap().clone();
    if let Some(f) = friction {
        so.friction = f;
    }
    let (problem, _) = SoProblem::build(&setup, &so).unwrap();
    (setup, so, problem)
}

/// The cell of the README's table row starting `| {row} |` in the column
/// headed `column`, or None.
pub fn readme_cell(row: &str, column: &str) -> Option<String> {
    doc_cell("README.md", row, column)
}

/// The cell of a table row starting `| {row} |` in the column headed
/// `column` of the Markdown file `doc` (relative to the repository, e.g.
/// `docs/validation.md`), or None.
pub fn doc_cell(doc: &str, row: &str, column: &str) -> Option<String> {
    let text = std::fs::read_to_string(PathBuf::from(env!("CARGO_MANIFEST_DIR")).join(doc)).ok()?;
    let lines: Vec<&str> = text.lines().collect();
    let cells = |l: &str| -> Vec<String> {
        l.trim()
            .trim_matches('|')
            .split(" | ")
            .map(|c| c.trim().to_string())
            .collect()
    };
    let r = lines
        .iter()
        .position(|l| l.starts_with(&format!("| {row} |")))?;
    // The header: the first table line above the row.
    let mut h = r;
    while h > 0 && lines[h - 1].starts_with('|') {
        h -= 1;
    }
    let j = cells(lines[h]).iter().position(|c| c == column)?;
    cells(lines[r]).get(j).cloned()
}

/// Column `label` of a table (panics naming the labels when it is absent).
pub fn col(t: &statopt::storage::Storage, label: &str) -> Vec<f64> {
    t.column(
        t.column_index(label)
            .unwrap_or_else(|| panic!("no column {label} in {:?}", t.labels)),
    )
}

/// Run an AnalyzeTool setup file with the default options (panics with the
/// error's message).
pub fn run_setup(p: &std::path::Path) -> statopt::tools::RunSummary {
    let s = match statopt::parse::setup::Setup::read(p).unwrap() {
        statopt::parse::setup::Setup::Analyze(s) => s,
        _ => unreachable!("not an AnalyzeTool setup: {}", p.display()),
    };
    statopt::tools::analyze::run(&s, &statopt::tools::RunOptions::default())
        .unwrap_or_else(|e| panic!("{e}"))
}
