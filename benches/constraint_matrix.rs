//! Building one frame's constraint matrix: analytic (one inverse-dynamics
//! pass, unit generalized forces projected on the coupling vectors) against
//! unit perturbation through forward dynamics (one forward-dynamics solve per
//! variable, as OpenSim's StaticOptimizationTarget), without the solve.
//! gait10dof18musc walking (28 variables; needs ../shared/validation, skips
//! with a message otherwise) and the leg extension machine (ten contacts,
//! setups/leg_extension_cam1.xml).
//! `cargo bench --bench constraint_matrix`

use std::path::{Path, PathBuf};

use criterion::{criterion_group, criterion_main, Criterion};
use statopt::dynamics::Data;
use statopt::muscles::set::MuscleFrame;
use statopt::parse::setup::Setup;
use statopt::tools::analyze::{frame_rows, load_states};
use statopt::tools::static_optimization::{ConstraintMatrix, SoProblem, StaticOptimizationSetup};

fn bench_setup(c: &mut Criterion, name: &str, setup_file: &Path) {
    let setup = match Setup::read(setup_file).unwrap() {
        Setup::Analyze(s) => s,
        _ => unreachable!(),
    };
    let (el, common) = setup
        .analysis_element("StaticOptimization")
        .map(|(e, c)| (e.clone(), c.clone()))
        .unwrap();
    let mut so = StaticOptimizationSetup::from_xml(&el, common).unwrap();
    let (mut problem, _) = SoProblem::build(&setup, &so).unwrap();
    let states = load_states(&setup, &problem.model).unwrap();
    let udot = states
        .speed_derivatives(setup.coordinates_file.as_ref().unwrap())
        .unwrap();
    let rows = frame_rows(&states.time, setup.initial_time, setup.final_time, 1);
    let i = rows[rows.len() / 2];
    let mut data = Data::new(&problem.model);
    let mut mf = MuscleFrame::new(&problem.muscles, &problem.model);
    for (label, m) in [
        ("analytic", ConstraintMatrix::Analytic),
        ("perturbation", ConstraintMatrix::Perturbation),
    ] {
        so.set_constraint_matrix(m);
        problem.options = statopt::frame::SoOptions::compile(&so);
        c.bench_function(&format!("constraint_matrix/{name}/{label}"), |b| {
            b.iter(|| {
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
                    .a[(0, 0)]
            })
        });
    }
}

fn bench(c: &mut Criterion) {
    let manifest = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let gait = manifest.join("../shared/validation/gait10dof18musc_walk/setup_SO.xml");
    if gait.is_file() {
        bench_setup(c, "gait10dof18musc", &gait);
    } else {
        eprintln!("SKIP constraint_matrix bench gait10dof18musc: ../shared/validation is absent");
    }
    bench_setup(
        c,
        "leg_extension_cam1",
        &manifest.join("setups/leg_extension_cam1.xml"),
    );
}

criterion_group!(benches, bench);
criterion_main!(benches);
