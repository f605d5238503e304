//! Per-frame cost of joint reactions (all joints, forces from OpenSim's
//! static-optimization force file) on the validation cases: forward dynamics,
//! muscle forces along their paths, reactions. Needs ../shared/validation.
//! `cargo bench --bench reactions`

use std::path::PathBuf;

use criterion::{criterion_group, criterion_main, Criterion};
use statopt::frame::Workspace;
use statopt::parse::setup::Setup;
use statopt::tools::analyze::{frame_rows, load_states};
use statopt::tools::joint_reaction::{JointReactionProblem, JointReactionSetup};

fn bench(c: &mut Criterion) {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../shared/validation");
    if !root.is_dir() {
        eprintln!("SKIP reactions bench: ../shared/validation is absent");
        return;
    }
    for case in ["arm26", "leg6dof9musc_stance", "gait10dof18musc_walk"] {
        let path = root.join(case).join("setup_JR_child.xml");
        let setup = match Setup::read(&path).unwrap() {
            Setup::Analyze(s) => s,
            _ => unreachable!(),
        };
        let jr: JointReactionSetup = setup.joint_reactions().next().unwrap().clone();
        let (problem, _) = JointReactionProblem::build(&setup, &jr).unwrap();
        let states = load_states(&setup, &problem.model).unwrap();
        let rows = frame_rows(&states.time, setup.initial_time, setup.final_time, 1);
        let mut ws = Workspace::new(&problem.model, &problem.muscles);
        let mut k = 0;
        c.bench_function(
            &format!(
                "joint_reaction_frame/{case} ({} reactions)",
                problem.specs.len()
            ),
            |b| {
                b.iter(|| {
                    let i = rows[k % rows.len()];
                    k += 1;
                    problem
                        .frame(states.time[i], &states.q[i], &states.u[i], &mut ws)
                        .unwrap()[0]
                })
            },
        );
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
