//! A frame allocates nothing (issue 16): once a thread's workspace and the
//! recycled output buffers have their sizes (a few frames), the work of a
//! frame of static optimization — kinematics, muscle paths, contacts, the
//! program's assembly, its dual Newton solve for every contact weight, the
//! frame's outputs and its joint reactions — makes no heap allocation, and
//! neither does the frame driver around it. Counted by a global allocator
//! with a per-thread counter. The exception, documented in
//! `optimize::solve`: a frame Newton leaves to Clarabel allocates
//! (Clarabel builds its solver each call); such frames are skipped here.

mod common;

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::path::{Path, PathBuf};

use statopt::frame::Workspace;
use statopt::motion::stream::{FrameSource, StateBlock};
use statopt::optimize::SolverKind;

use statopt::tools::analyze;
use statopt::tools::joint_reaction::resolve_reactions;
use statopt::tools::static_optimization::{frame_outputs, FrameOutput};

struct Counting;

thread_local! {
    static ALLOCATIONS: Cell<u64> = const { Cell::new(0) };
}

fn bump() {
    let _ = ALLOCATIONS.try_with(|c| c.set(c.get() + 1));
}

/// Allocations made so far on this thread.
fn allocations() -> u64 {
    ALLOCATIONS.with(|c| c.get())
}

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        bump();
        System.alloc(layout)
    }
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        bump();
        System.alloc_zeroed(layout)
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        bump();
        System.realloc(ptr, layout, new_size)
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        System.dealloc(ptr, layout)
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

/// Every frame of the setup's motion through `frame_outputs` (all contact
/// weights, the coupled JointReactions), counting each frame's allocations.
/// Returns the frames checked.
fn check_setup(setup_file: &Path) -> usize {
    let (setup, so, problem) = common::so_case(setup_file, None);
    let mut reactions = Vec::new();
    for jr in setup.joint_reactions() {
        reactions.push(resolve_reactions(&problem.model, jr).unwrap().0);
    }
    let reactions: Vec<&[_]> = reactions.iter().map(|r| r.as_slice()).collect();
    let weights = if problem.contacts.is_empty() {
        vec![so.contact_weights[0]]
    } else {
        so.contact_weights.clone()
    };
    let states = analyze::load_states_with(&setup, &problem.model, &problem.contacts).unwrap();
    let udot = states
        .speed_derivatives(setup.coordinates_file.as_ref().unwrap())
        .unwrap();
    let rows = analyze::frame_rows(&states.time, setup.initial_time, setup.final_time, 1);
    let mut ws = Workspace::new(&problem.model, &problem.muscles);
    let mut out: Vec<FrameOutput> = Vec::new();
    let mut allocating = Vec::new();
    let mut checked = 0;
    // The first pass gives every buffer the largest size the motion needs
    // (a frame may need more than the frames before it: a muscle path
    // wrapping, with more points; measured: gait2392 allocates in its
    // first frame only, leg extension cam 1 in its first and at t = 3.55 s,
    // where a path point vector grows); the second must allocate nothing.
    for pass in 0..2 {
        for &i in &rows {
            let before = allocations();
            frame_outputs(
                &problem,
                &weights,
                &reactions,
                &mut ws,
                states.time[i],
                &states.q[i],
                &states.u[i],
                &udot[i],
                // Warm-started, as the run's frames after a group's first.
                true,
                &mut out,
            )
            .unwrap();
            let n = allocations() - before;
            assert_eq!(out.len(), weights.len());
            let clarabel = out
                .iter()
                .any(|(r, _)| r.solution.solver == SolverKind::Clarabel);
            if pass == 0 || clarabel {
                continue;
            }
            checked += 1;
            if n > 0 {
                allocating.push((states.time[i], n));
            }
        }
    }
    assert!(
        allocating.is_empty(),
        "{}: {} of {checked} frames allocate in the second pass (time, allocations): {:?}",
        setup_file.display(),
        allocating.len(),
        &allocating[..allocating.len().min(8)]
    );
    checked
}

#[test]
fn a_leg_extension_frame_allocates_nothing() {
    // Ten frictional contacts, three contact weights, knee reactions.
    let file = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("setups/leg_extension_cam1.xml");
    let checked = check_setup(&file);
    assert!(checked > 90, "only {checked} frames checked");
}

#[test]
fn a_gait2392_frame_allocates_nothing() {
    let file = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../shared/models/gait2392/subject01_walk/setup_SO.xml");
    if !file.is_file() {
        eprintln!(
            "SKIP a_gait2392_frame_allocates_nothing: {} is absent",
            file.display()
        );
        return;
    }
    let checked = check_setup(&file);
    assert!(checked > 100, "only {checked} frames checked");
}

/// `n` rows in one block (times only).
struct Rows(Option<usize>);

impl FrameSource for Rows {
    fn next_block(&mut self) -> statopt::error::Result<Option<StateBlock>> {
        Ok(self.0.take().map(|n| StateBlock {
            first: 0,
            time: (0..n).map(|i| i as f64).collect(),
            ..StateBlock::default()
        }))
    }
}

/// Allocations of the frame driver itself over `n` frames of work that
/// allocates nothing, on one worker thread.
fn driver_allocations(n: usize) -> u64 {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    pool.install(|| {
        let mut rows = Rows(Some(n));
        // The block is made before counting.
        let block = rows.next_block().unwrap();
        struct One(Option<StateBlock>);
        impl FrameSource for One {
            fn next_block(&mut self) -> statopt::error::Result<Option<StateBlock>> {
                Ok(self.0.take())
            }
        }
        let mut one = One(block);
        let before = allocations();
        let mut sum = 0.0;
        statopt::frame::driver::for_each_frame(
            &mut one,
            0,
            n - 1,
            1,
            || [0.0f64; 64],
            |w, b, i| {
                w[i % 64] += b.time[i];
                Ok(w[i % 64])
            },
            |v| {
                sum += v;
                Ok(())
            },
        )
        .unwrap();
        assert!(sum > 0.0);
        allocations() - before
    })
}

#[test]
fn the_frame_driver_allocates_nothing_per_frame() {
    // What the driver allocates once per run or block (the block's frame
    // selection, the chunk's result buffer, the workspace pool) does not
    // grow with the frames: at most a handful, for 200 frames (7 chunks)
    // as for 20000 (625 chunks). (Before the workspace pool and the reused
    // result buffer: 15 and 136 allocations for 200 and 4000 frames.)
    for n in [200, 4000, 20000] {
        let count = driver_allocations(n);
        assert!(
            count <= 8,
            "the frame driver allocates per frame or per chunk: {count} allocations for {n} frames"
        );
    }
}
