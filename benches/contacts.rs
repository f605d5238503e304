//! Per-frame static-optimization cost with 10 point-on-plane contacts on a
//! 92-muscle model (gait2392 walking, contacts between feet/pelvis/thighs
//! and ground planes), friction pyramid vs cone, and without contacts.
//! Needs ../shared/models (skips with a message otherwise).
//! `cargo bench --bench contacts`

use std::path::PathBuf;

use criterion::{criterion_group, criterion_main, Criterion};
use statopt::dynamics::Data;
use statopt::muscles::set::MuscleFrame;
use statopt::parse::setup::Setup;
use statopt::tools::analyze::{frame_rows, load_states};
use statopt::tools::static_optimization::{SoProblem, StaticOptimizationSetup};

const CONTACTS: [(&str, &str); 10] = [
    ("calcn_r", "0 -0.01 0"),
    ("calcn_r", "0.18 -0.01 0.02"),
    ("toes_r", "0.04 -0.005 0"),
    ("calcn_l", "0 -0.01 0"),
    ("calcn_l", "0.18 -0.01 -0.02"),
    ("toes_l", "0.04 -0.005 0"),
    ("pelvis", "-0.1 -0.1 0.08"),
    ("pelvis", "-0.1 -0.1 -0.08"),
    ("femur_r", "0 -0.3 0"),
    ("femur_l", "0 -0.3 0"),
];

fn bench(c: &mut Criterion) {
    let root =
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../shared/models/gait2392/subject01_walk");
    if !root.is_dir() {
        eprintln!("SKIP contacts bench: ../shared/models is absent");
        return;
    }
    let dir = std::env::temp_dir().join(format!("statopt-bench-contacts-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let model =
        std::fs::read_to_string(root.join("inputs/subject01_simbody_adjusted.osim")).unwrap();
    let contacts: String = CONTACTS
        .iter()
        .enumerate()
        .map(|(k, (body, p))| {
            format!(
                "<PointOnPlaneContact name=\"c{k}\"><point_body>{body}</point_body><point_location>{p}</point_location><plane_body>ground</plane_body><plane_origin>0 0 0</plane_origin><plane_normal>0 1 0</plane_normal></PointOnPlaneContact>"
            )
        })
        .collect();
    let pos = model
        .find("</objects>\n\t\t</ForceSet>")
        .or_else(|| {
            model
                .rfind("</ForceSet>")
                .map(|p| model[..p].rfind("</objects>").unwrap())
        })
        .unwrap();
    std::fs::write(
        dir.join("model.osim"),
        format!("{}{}{}", &model[..pos], contacts, &model[pos..]),
    )
    .unwrap();
    let setup_text = std::fs::read_to_string(root.join("setup_SO.xml")).unwrap();
    let setup_text = setup_text
        .replace(
            "<model_file>inputs/subject01_simbody_adjusted.osim</model_file>",
            &format!(
                "<model_file>{}</model_file>",
                dir.join("model.osim").display()
            ),
        )
        .replace(">inputs/", &format!(">{}/inputs/", root.display()))
        .replace(" inputs/", &format!(" {}/inputs/", root.display()));
    std::fs::write(dir.join("setup.xml"), setup_text).unwrap();
    let setup = match Setup::read(&dir.join("setup.xml")).unwrap() {
        Setup::Analyze(s) => s,
        _ => unreachable!(),
    };
    let (el, common) = setup
        .analysis_element("StaticOptimization")
        .map(|(e, c)| (e.clone(), c.clone()))
        .unwrap();
    for (label, xml) in [
        ("cone", "<friction_cone>cone</friction_cone>"),
        ("pyramid", "<friction_cone>pyramid</friction_cone>"),
    ] {
        let mut el = el.clone();
        let extra = statopt::xml::parse_str(
            &format!("<x>{xml}<contact_weight>1000</contact_weight></x>"),
            std::path::Path::new("bench"),
        )
        .unwrap();
        el.children.extend(extra.children);
        let so = StaticOptimizationSetup::from_xml(&el, common.clone()).unwrap();
        let (problem, _) = SoProblem::build(&setup, &so).unwrap();
        let states = load_states(&setup, &problem.model).unwrap();
        let udot = states
            .speed_derivatives(setup.coordinates_file.as_ref().unwrap())
            .unwrap();
        let rows = frame_rows(&states.time, setup.initial_time, setup.final_time, 1);
        let mut data = Data::new(&problem.model);
        let mut mf = MuscleFrame::new(&problem.muscles, &problem.model);
        let n = rows.len();
        let mut k = 0;
        c.bench_function(
            &format!("so_frame/gait2392_92_muscles_10_contacts/{label}"),
            |b| {
                b.iter(|| {
                    let i = rows[k % n];
                    k += 1;
                    problem
                        .solve_frame(
                            states.time[i],
                            &states.q[i],
                            &states.u[i],
                            &udot[i],
                            &mut data,
                            &mut mf,
                        )
                        .solution
                        .objective
                })
            },
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}

criterion_group!(benches, bench);
criterion_main!(benches);
