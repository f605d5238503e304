//! The per-frame solve alone, dual Newton against Clarabel, on the real
//! frame problems of gait2392 walking (92 muscles, 23 equations; the
//! setup's 151 frames, assembled once before timing). Needs ../shared/models
//! (skips with a message otherwise). `cargo bench --bench solver`

use std::path::PathBuf;

use criterion::{criterion_group, criterion_main, Criterion};
use statopt::dynamics::Data;
use statopt::muscles::set::MuscleFrame;
use statopt::optimize::{self, FrameProblem, SolverChoice};
use statopt::parse::setup::Setup;
use statopt::tools::analyze::{frame_rows, load_states};
use statopt::tools::static_optimization::{SoProblem, StaticOptimizationSetup};

fn bench(c: &mut Criterion) {
    let file = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../shared/models/gait2392/subject01_walk/setup_SO.xml");
    if !file.is_file() {
        eprintln!("SKIP solver bench: {} is absent", file.display());
        return;
    }
    let setup = match Setup::read(&file).unwrap() {
        Setup::Analyze(s) => s,
        _ => unreachable!(),
    };
    let (el, common) = setup
        .analysis_element("StaticOptimization")
        .map(|(e, c)| (e.clone(), c.clone()))
        .unwrap();
    let so = StaticOptimizationSetup::from_xml(&el, common).unwrap();
    let (problem, _) = SoProblem::build(&setup, &so).unwrap();
    let states = load_states(&setup, &problem.model).unwrap();
    let udot = states
        .speed_derivatives(setup.coordinates_file.as_ref().unwrap())
        .unwrap();
    let rows = frame_rows(&states.time, setup.initial_time, setup.final_time, 1);
    let mut data = Data::new(&problem.model);
    let mut mf = MuscleFrame::new(&problem.muscles, &problem.model);
    let frames: Vec<FrameProblem> = rows
        .iter()
        .map(|&i| {
            problem
                .frame_problem(
                    states.time[i],
                    &states.q[i],
                    &states.u[i],
                    &udot[i],
                    &mut data,
                    &mut mf,
                )
                .0
        })
        .collect();
    for (label, choice) in [
        ("newton", SolverChoice::Auto),
        ("clarabel", SolverChoice::Clarabel),
    ] {
        let frames: Vec<FrameProblem> = frames
            .iter()
            .cloned()
            .map(|mut p| {
                p.settings.solver = choice;
                p
            })
            .collect();
        let mut k = 0;
        c.bench_function(&format!("so_solve/gait2392_92_muscles/{label}"), |b| {
            b.iter(|| {
                let p = &frames[k % frames.len()];
                k += 1;
                optimize::solve(p).objective
            })
        });
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
