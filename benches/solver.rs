//! The per-frame solve alone, dual Newton against Clarabel, on the real
//! frame problems of gait2392 walking (92 muscles, 23 equations; every
//! row of the motion in the setup's time range, 1500 frames, assembled
//! once before timing). `newton` is `optimize::solve` as the drivers call
//! it for the first frame of a group (cold start); `newton_warm` starts each
//! frame from the previous
//! frame's multipliers. Needs ../shared/models
//! (skips with a message otherwise). `cargo bench --bench solver`

use std::path::PathBuf;

use criterion::{criterion_group, criterion_main, Criterion};
use statopt::dynamics::Data;
use statopt::muscles::set::MuscleFrame;
use statopt::optimize::{self, dual, FrameProblem, SolverChoice};
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

    // Warm start: each frame from the multipliers of the frame before
    // (computed beforehand, cold), through a reused workspace. The drivers
    // do this inside fixed groups of frames (`frame::driver::GROUP`: the
    // first of a group cold, the others warm, so results do not depend on
    // the order frames are solved in); `newton` above is the cold start.
    let ys: Vec<Vec<f64>> = frames
        .iter()
        .map(|p| dual::solve_dual(p, None).unwrap().y)
        .collect();
    let mut ws = dual::DualWorkspace::new();
    let mut k = 1;
    c.bench_function("so_solve/gait2392_92_muscles/newton_warm", |b| {
        b.iter(|| {
            let i = k % frames.len();
            let i = if i == 0 { 1 } else { i };
            k += 1;
            ws.solve(&frames[i], Some(&ys[i - 1])).unwrap().iterations
        })
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
