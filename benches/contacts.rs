//! Per-frame static-optimization cost with 10 point-on-plane contacts on a
//! 92-muscle model (gait2392 walking, contacts between feet/pelvis/thighs
//! and ground planes), friction pyramid vs cone, and without contacts.
//! Needs ../shared/models (skips with a message otherwise).
//! `cargo bench --bench contacts`

use criterion::{criterion_group, criterion_main, Criterion};
use statopt::dynamics::Data;
use statopt::muscles::set::MuscleFrame;
use statopt::parse::setup::Setup;
use statopt::tools::analyze::{frame_rows, load_states};
use statopt::tools::static_optimization::{SoProblem, StaticOptimizationSetup};

#[path = "../tests/common/contact_scene.rs"]
mod contact_scene;

fn bench(c: &mut Criterion) {
    let dir = std::env::temp_dir().join(format!("statopt-bench-contacts-{}", std::process::id()));
    let Some(file) = contact_scene::write_scene("contacts bench", &dir) else {
        return;
    };
    let setup = match Setup::read(&file).unwrap() {
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
