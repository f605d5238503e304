//! `statopt-tool SETUP.xml`: run the tool an OpenSim-style setup file describes.
//! `statopt-tool bench SETUP.xml`: measure frames per second.
//! `statopt-tool scene SETUP.xml -o scene.osim`: write the composed model.
//! `statopt-tool motion --model M.osim --coordinate q --from A --to B --duration T -o out.mot`:
//! write a minimum-jerk motion.
//!
//! Exit status: 0 success, 2 bad input (a file, element or option is wrong),
//! 3 some frames could not be solved (every output is written; see the
//! diagnostics table), 1 internal failure.

use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Args, Parser, Subcommand};
use statopt::parse::setup::Setup;
use statopt::tools::{self, bench, bench_grid, RunOptions};

#[derive(Parser, Debug)]
#[command(
    name = "statopt-tool",
    version,
    args_conflicts_with_subcommands = true,
    subcommand_negates_reqs = true,
    about = "Estimate muscle and contact forces from a motion: runs OpenSim-style setup files (InverseDynamicsTool, AnalyzeTool with MuscleAnalysis / StaticOptimization).",
    long_about = "Reads one XML setup file (OpenSim InverseDynamicsTool / AnalyzeTool style), runs the tool it \
describes, and writes OpenSim .sto tables. Paths inside the setup are relative to the setup file's folder, \
as in OpenSim.\n\nExit status: 0 on success, 2 when the input is wrong (the message names the file, element \
and line), 3 when some frames could not be solved (every output is still written; the diagnostics table \
says which), 1 on an internal failure."
)]
struct Cli {
    #[command(subcommand)]
    command: Option<Command>,
    #[command(flatten)]
    run: RunArgs,
}

#[derive(Args, Debug)]
struct RunArgs {
    /// The setup file (e.g. setup_SO.xml).
    #[arg(required = true)]
    setup: Option<PathBuf>,
    /// Write results here instead of the setup's <results_directory>.
    #[arg(short = 'o', long = "results-dir", value_name = "DIR")]
    results_dir: Option<PathBuf>,
    /// Digits after the decimal point in .sto files (default: the setup's output_precision, or 8).
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u8).range(1..=20))]
    precision: Option<u8>,
    /// Worker threads for the per-frame work (default: all cores). Results do not depend on it.
    #[arg(short = 'j', long, value_name = "N", value_parser = clap::value_parser!(u16).range(1..))]
    threads: Option<u16>,
    /// Print nothing but errors (unsolved frames are always said).
    #[arg(short, long)]
    quiet: bool,
    /// Run static optimization on the model reduced to what the motion needs
    /// (overrides the setup's <reduce_model>).
    #[arg(long)]
    reduce: bool,
    /// Read and compile everything the setup (or study) names and report every
    /// problem found, without running; exit 2 if there is one.
    #[arg(long)]
    check: bool,
    /// Continue a stopped or killed run: static optimization keeps the frames its tables and
    /// log hold completely and computes the rest (tables equal an uninterrupted run's).
    #[arg(long)]
    resume: bool,
    /// Return only once every output file is on the disk itself (fsync), so that it survives a
    /// power cut; without it files are closed as OpenSim closes them.
    #[arg(long)]
    sync: bool,
    /// Read on past elements of a setup or study document that neither OpenSim 4.6 nor statopt
    /// knows, with a warning (without it they are errors: a misspelled property would silently
    /// take its default).
    #[arg(long)]
    allow_unknown: bool,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Run an AnalyzeTool setup repeatedly and report frames per second and peak memory.
    Bench {
        /// The setup file.
        setup: PathBuf,
        /// Thread counts to measure, comma-separated.
        #[arg(long, value_delimiter = ',', default_value = "1,2")]
        threads: Vec<usize>,
        /// Runs per thread count (the best is reported).
        #[arg(long, default_value_t = 3)]
        repeat: usize,
        /// Repeat the motion this many times end to end first (trial length scaling).
        #[arg(long, default_value_t = 1)]
        tile: usize,
        /// Override the setup's coordinate low-pass cut-off (Hz; -1: no filtering).
        #[arg(long, allow_hyphen_values = true)]
        lowpass: Option<f64>,
        /// Run a grid of method choices (constraint matrix, friction model, solver
        /// tolerance, spline, filter, threads) against a reference run; writes
        /// bench_grid.csv and bench_grid.png/.svg into --out.
        #[arg(long)]
        grid: bool,
        /// Output folder of --grid.
        #[arg(long, value_name = "DIR", default_value = ".", requires = "grid")]
        out: PathBuf,
        /// OpenSim 4.6's time per frame (ms), drawn as a reference line (--grid).
        #[arg(long, value_name = "MS", requires = "grid")]
        opensim_ms: Option<f64>,
        /// OpenSim's *_StaticOptimization_activation.sto of the setup: the grid
        /// reports max |Δactivation| against it.
        #[arg(long, value_name = "FILE", requires = "grid")]
        opensim_activations: Option<PathBuf>,
        /// The contact weight w0 of every --grid run (default: the setup's first).
        #[arg(long, value_name = "W0", requires = "grid")]
        contact_weight: Option<f64>,
    },
    /// Write the model a setup composes (model_file + artifact_files + force_set_files, contact
    /// elements left out) as one OpenSim 4.x document.
    Scene {
        /// The setup file (AnalyzeTool or InverseDynamicsTool).
        setup: PathBuf,
        /// The .osim file to write.
        #[arg(short = 'o', long = "output", value_name = "FILE")]
        output: PathBuf,
    },
    /// Predict ground reactions from kinematics alone: the setup's static optimization with foot
    /// contacts built from the model's feet; its external loads, if any, are the measured
    /// reference (not applied). Writes <name>_predicted_grf.sto, <name>_foot_contacts.xml and,
    /// with measured loads, <name>_grf_comparison.csv.
    #[command(name = "predict-grf")]
    PredictGrf {
        /// An AnalyzeTool setup with a StaticOptimization analysis.
        setup: PathBuf,
        /// Write results here instead of the setup's <results_directory>.
        #[arg(short = 'o', long = "results-dir", value_name = "DIR")]
        results_dir: Option<PathBuf>,
        /// The floor's height (ground y, m), level: instead of finding the floor, each foot
        /// point's resting height and the floor's tilt from the motion.
        #[arg(long, value_name = "Y", allow_negative_numbers = true)]
        floor_height: Option<f64>,
        /// The floor is a treadmill belt running backward at SPEED (m/s) along the walking
        /// direction, or with velocity VX,VY,VZ (m/s, ground): instead of deciding from the motion.
        #[arg(
            long,
            value_name = "SPEED|VX,VY,VZ",
            allow_hyphen_values = true,
            conflicts_with = "overground"
        )]
        treadmill: Option<String>,
        /// The floor is the ground (no belt): instead of deciding from the motion.
        #[arg(long)]
        overground: bool,
        /// Read on past elements of the setup that neither OpenSim 4.6 nor statopt knows, with a
        /// warning (without it they are errors).
        #[arg(long)]
        allow_unknown: bool,
        /// Print nothing but errors.
        #[arg(short, long)]
        quiet: bool,
    },
    /// The setup's static optimization with statopt's knee contact method (docs/knee_contact.md):
    /// each knee's medial and lateral compartments as unknown forces of the optimisation, each
    /// costing (load / capacity)^2 like a muscle; the knee's capacity 3.46 body weights, 65 % of it
    /// medial (the StaticOptimization's <knee_contact_capacity> (half the knee's) and
    /// <knee_contact_medial_share> set others). Writes the usual tables, <name>_KneeContact.sto (per knee: flexion, total, medial and
    /// lateral force) and its figure.
    #[command(name = "knee-contact")]
    KneeContact {
        /// An AnalyzeTool setup with a StaticOptimization analysis.
        setup: PathBuf,
        /// Write results here instead of the setup's <results_directory>.
        #[arg(short = 'o', long = "results-dir", value_name = "DIR")]
        results_dir: Option<PathBuf>,
        /// A knee joint to solve so (repeatable; default: every joint whose child is a tibia_* body).
        #[arg(long = "joint", value_name = "J")]
        joints: Vec<String>,
        /// Print nothing but errors.
        #[arg(short, long)]
        quiet: bool,
    },
    /// How well static optimization's activations agree with measured EMG (docs/emg_compare.md):
    /// per channel, Pearson r and on/off agreement of the activation of the muscle(s) it records
    /// with the EMG envelope at the activation file's frames, and the electromechanical delay
    /// (0-100 ms) that maximises r. Writes OUT.csv and a figure OUT.png/.svg.
    #[command(name = "emg-compare")]
    EmgCompare {
        /// The EMG envelopes (.sto/.mot; one column per channel).
        emg: PathBuf,
        /// Activation tables (<name>_StaticOptimization_activation.sto), one or more.
        #[arg(required = true)]
        activations: Vec<PathBuf>,
        /// Channel to muscle map: lines 'channel: muscle [muscle ...]' (a group is averaged),
        /// '#' comments. Default: the Rajagopal model's muscles for the ten channels of its
        /// gait EMG.
        #[arg(long, value_name = "FILE")]
        map: Option<PathBuf>,
        /// The side whose muscles the default map names.
        #[arg(long, default_value = "r", value_parser = ["r", "l"])]
        side: String,
        /// Electromechanical delay: the EMG at t - D is compared with the activation at t.
        #[arg(
            long = "delay-ms",
            value_name = "D",
            default_value_t = 0.0,
            allow_hyphen_values = true
        )]
        delay_ms: f64,
        /// A signal is on at and above this fraction of its peak over the compared frames.
        #[arg(long = "on-fraction", value_name = "F", default_value_t = tools::emg_compare::DEFAULT_ON_FRACTION)]
        on_fraction: f64,
        /// A name per activation file for the table and figure (default: its folder's name).
        #[arg(long = "label", value_name = "NAME")]
        labels: Vec<String>,
        /// Output stem: writes STEM.csv, STEM.png and STEM.svg.
        #[arg(
            short = 'o',
            long = "output",
            value_name = "STEM",
            default_value = "emg_compare"
        )]
        output: PathBuf,
    },
    /// Write a .mot in which a coordinate moves from --from to --to along a minimum-jerk
    /// (bell-shaped velocity) profile, optionally back and repeated with holds; every other
    /// coordinate stays at its default value unless linked, or solved so that contacts stay
    /// closed (--touch) or planted (--plant), all together, within 1e-9 m on every row.
    Motion {
        /// The model (give --model or --setup).
        #[arg(
            long,
            value_name = "FILE",
            required_unless_present = "setup",
            conflicts_with = "setup"
        )]
        model: Option<PathBuf>,
        /// Artifact models merged into --model (repeatable).
        #[arg(long = "artifact", value_name = "FILE", requires = "model")]
        artifacts: Vec<PathBuf>,
        /// Take the model and artifact_files from this setup instead.
        #[arg(long, value_name = "FILE")]
        setup: Option<PathBuf>,
        /// The driven coordinate.
        #[arg(long, value_name = "NAME")]
        coordinate: String,
        /// Start value (degrees for rotational coordinates, model units otherwise).
        #[arg(long, allow_negative_numbers = true)]
        from: f64,
        /// End value (same units).
        #[arg(long, allow_negative_numbers = true)]
        to: f64,
        /// Duration of the movement, s.
        #[arg(long)]
        duration: f64,
        /// Rows per second.
        #[arg(long, default_value_t = 100.0)]
        rate: f64,
        /// Another coordinate following the same profile (repeatable).
        #[arg(long, value_name = "NAME")]
        also: Vec<String>,
        /// A coordinate following a linear relation in file units, e.g.
        /// lever_angle=1*knee_angle_r+0 (repeatable, applied in order).
        #[arg(long, value_name = "TARGET=A*SOURCE+B", allow_hyphen_values = true)]
        link: Vec<String>,
        /// Keep CONTACT's point on its plane on every row by solving COORDINATE. Repeatable; all
        /// --touch and --plant contacts are solved together over all their coordinates (a contact
        /// or coordinate may appear more than once), each within 1e-9 m on every row.
        #[arg(long, value_name = "CONTACT=COORDINATE")]
        touch: Vec<String>,
        /// Close CONTACT and keep its point where it was on the first row, in the plane body's
        /// frame (two in-plane conditions), solving the coordinates given too. Repeatable.
        #[arg(long, value_name = "CONTACT[=COORD,...]")]
        plant: Vec<String>,
        /// After the movement (and --hold-end), move back to --from (minimum jerk).
        #[arg(long = "return")]
        back: bool,
        /// Seconds of the way back (default: --duration).
        #[arg(long, value_name = "S", requires = "back")]
        return_duration: Option<f64>,
        /// Seconds held at --from before each movement.
        #[arg(long, value_name = "S", default_value_t = 0.0)]
        hold_start: f64,
        /// Seconds held at --to after each movement.
        #[arg(long, value_name = "S", default_value_t = 0.0)]
        hold_end: f64,
        /// Repetitions (hold, there, hold, back) end to end; more than one needs --return.
        #[arg(long, value_name = "N", default_value_t = 1)]
        repeat: usize,
        /// A force-set file holding contacts for --touch and --plant (repeatable; with --setup its
        /// force_set_files are used too).
        #[arg(long = "force-set", value_name = "FILE")]
        force_sets: Vec<PathBuf>,
        /// Digits after the decimal point (contacts are checked closed on the rounded values).
        #[arg(long, default_value_t = 10, value_parser = clap::value_parser!(u8).range(1..=20))]
        precision: u8,
        /// The .mot file to write.
        #[arg(short = 'o', long = "output", value_name = "FILE")]
        output: PathBuf,
    },
}

fn run_scene(setup: &std::path::Path, output: &std::path::Path) -> statopt::Result<()> {
    let (model, artifacts, force_sets, replace) = match Setup::read(setup)? {
        Setup::Analyze(s) => (
            s.model_file,
            s.artifact_files,
            s.force_set_files,
            s.replace_force_set,
        ),
        Setup::InverseDynamics(s) => (s.model_file, s.artifact_files, Vec::new(), false),
    };
    let scene = statopt::tools::scene::compose_scene(&model, &artifacts, &force_sets, replace)?;
    statopt::tools::scene::write_document(&scene.document, output)?;
    for w in &scene.spec.warnings {
        eprintln!("warning: {w}");
    }
    if !scene.omitted_contacts.is_empty() {
        eprintln!(
            "note: contact elements left out (OpenSim does not know them): {}",
            scene.omitted_contacts.join(", ")
        );
    }
    let forces = scene
        .document
        .path(&["Model", "ForceSet", "objects"])
        .map_or(0, |o| o.children.len());
    eprintln!(
        "wrote {} ({} bodies, {} joints, {} forces)",
        output.display(),
        scene.spec.bodies.len(),
        scene.spec.joints.len(),
        forces
    );
    Ok(())
}

fn run_motion(cmd: &Command) -> statopt::Result<()> {
    let Command::Motion {
        model,
        artifacts,
        setup,
        coordinate,
        from,
        to,
        duration,
        rate,
        also,
        link,
        touch,
        plant,
        back,
        return_duration,
        hold_start,
        hold_end,
        repeat,
        force_sets,
        precision,
        output,
    } = cmd
    else {
        return Err(statopt::Error::internal(
            "run_motion called for another command",
        ));
    };
    let mut force_set_files = force_sets.clone();
    let (model_file, artifact_files) = match (model, setup) {
        (Some(m), _) => (m.clone(), artifacts.clone()),
        // The setup's motion is the file this command writes: it may not exist yet.
        (None, Some(s)) => match Setup::read_for_model(s)? {
            Setup::Analyze(s) => {
                force_set_files.extend(s.force_set_files);
                (s.model_file, s.artifact_files)
            }
            Setup::InverseDynamics(s) => (s.model_file, s.artifact_files),
        },
        (None, None) => return Err(statopt::Error::msg("give --model or --setup")),
    };
    let (spec, compiled) = tools::loading::load_composed_model(&model_file, &artifact_files)?;
    let mut forces = spec.forces.clone();
    for f in &force_set_files {
        forces.extend(statopt::forces::read_force_set_file(f)?);
    }
    let motion = tools::motion_gen::MinJerkMotion {
        coordinate: coordinate.clone(),
        also: also.clone(),
        from: *from,
        to: *to,
        duration: *duration,
        rate: *rate,
        links: link
            .iter()
            .map(|l| tools::motion_gen::parse_link(l))
            .collect::<statopt::Result<_>>()?,
        touch: touch
            .iter()
            .map(|t| tools::motion_gen::parse_touch(t))
            .collect::<statopt::Result<_>>()?,
        plant: plant
            .iter()
            .map(|t| tools::motion_gen::parse_plant(t))
            .collect::<statopt::Result<_>>()?,
        repeat: *repeat,
        hold_start: *hold_start,
        hold_end: *hold_end,
        back: *back,
        return_duration: *return_duration,
        precision: Some(usize::from(*precision)),
    };
    let (table, warnings) = tools::motion_gen::generate(&compiled, &motion, &forces)?;
    for w in &warnings {
        eprintln!("warning: {w}");
    }
    statopt::storage::write(output, &table, usize::from(*precision))?;
    eprintln!(
        "wrote {} ({} rows, {} coordinates)",
        output.display(),
        table.len(),
        table.labels.len()
    );
    Ok(())
}

fn run_setup(a: &RunArgs) -> statopt::Result<tools::RunSummary> {
    let opts = RunOptions {
        results_dir: a.results_dir.clone(),
        precision: a.precision.map(usize::from),
        verbose: !a.quiet,
        threads: a.threads.map(usize::from),
        resume: a.resume,
        reduce: a.reduce,
        sync: a.sync,
        progress: None,
        allow_unknown: a.allow_unknown,
        read_on_hook: Some(warn_read_on),
    };
    let setup = a
        .setup
        .as_ref()
        .ok_or_else(|| statopt::Error::msg("no setup file given"))?;
    tools::run_setup(setup, &opts)
}

/// The unknown elements `--allow-unknown` read on past, printed as the
/// setup is read (a run that fails later has said them), and not again in
/// the run's summary.
static READ_ON: std::sync::Mutex<Vec<String>> = std::sync::Mutex::new(Vec::new());

fn warn_read_on(w: &str) {
    eprintln!("warning: {w}");
    READ_ON.lock().unwrap().push(w.to_string());
}

fn fail(e: statopt::Error) -> ExitCode {
    eprintln!("error: {e}");
    ExitCode::from(e.exit_code() as u8)
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    if let Err(e) = tools::interrupt::install() {
        return fail(e);
    }
    match &cli.command {
        Some(Command::Bench {
            setup,
            threads,
            repeat,
            tile,
            lowpass,
            grid,
            out,
            opensim_ms,
            opensim_activations,
            contact_weight,
        }) => {
            if *grid {
                let opts = bench_grid::GridOptions {
                    out: out.clone(),
                    repeat: *repeat,
                    opensim_ms: *opensim_ms,
                    opensim_activations: opensim_activations.clone(),
                    contact_weight: *contact_weight,
                };
                return match bench_grid::run(setup, &opts) {
                    Ok((rows, files)) => {
                        println!("choice\tthreads\tframes\tms_per_frame\tmax_da\trms_da\tmax_dcontact_N\tmax_dreaction_N\tmax_da_opensim\tfailed");
                        let o = |v: Option<f64>| {
                            v.map(|x| format!("{x:.3e}")).unwrap_or_else(|| "-".into())
                        };
                        for r in rows {
                            println!(
                                "{}\t{}\t{}\t{:.4}\t{:.3e}\t{:.3e}\t{}\t{}\t{}\t{}",
                                r.choice,
                                r.threads,
                                r.frames,
                                r.ms_per_frame,
                                r.max_dactivation,
                                r.rms_dactivation,
                                o(r.max_dcontact),
                                o(r.max_dreaction),
                                o(r.max_dactivation_opensim),
                                r.failed_frames
                            );
                        }
                        for f in files {
                            println!("wrote {}", f.display());
                        }
                        ExitCode::SUCCESS
                    }
                    Err(e) => fail(e),
                };
            }
            let opts = bench::BenchOptions {
                threads: threads.clone(),
                repeat: *repeat,
                tile: *tile,
                lowpass: *lowpass,
            };
            match bench::run(setup, &opts) {
                Ok(rows) => {
                    println!("setup\tthreads\tframes\tloop_s\tframes_per_s\tms_per_frame\ttotal_s\tpeak_MiB\tcpu_ms_per_frame");
                    let mem = bench::peak_memory_mib()
                        .map(|m| format!("{m:.1}"))
                        .unwrap_or_else(|| "n/a".into());
                    for r in rows {
                        let cpu = r
                            .cpu_seconds_per_frame
                            .map(|c| format!("{:.4}", 1e3 * c))
                            .unwrap_or_else(|| "n/a".into());
                        println!(
                            "{}\t{}\t{}\t{:.4}\t{:.0}\t{:.4}\t{:.3}\t{}\t{}",
                            setup.display(),
                            r.threads,
                            r.frames,
                            r.loop_seconds,
                            r.frames as f64 / r.loop_seconds,
                            1e3 * r.loop_seconds / r.frames as f64,
                            r.total_seconds,
                            mem,
                            cpu
                        );
                    }
                    ExitCode::SUCCESS
                }
                Err(e) => fail(e),
            }
        }
        Some(Command::PredictGrf {
            setup,
            results_dir,
            floor_height,
            treadmill,
            overground,
            allow_unknown,
            quiet,
        }) => {
            let opts = RunOptions {
                results_dir: results_dir.clone(),
                verbose: !quiet,
                allow_unknown: *allow_unknown,
                ..Default::default()
            };
            let motion = match (treadmill, overground) {
                (Some(t), _) => match tools::predict_grf::parse_treadmill(t) {
                    Ok(m) => m,
                    Err(e) => return fail(e),
                },
                (None, true) => tools::predict_grf::FloorMotion::Overground,
                (None, false) => tools::predict_grf::FloorMotion::Auto,
            };
            let floor = tools::predict_grf::FloorOptions {
                height: *floor_height,
                motion,
            };
            let run = match statopt::parse::setup::Setup::read_with(setup, *allow_unknown) {
                Ok(statopt::parse::setup::Setup::Analyze(s)) => {
                    tools::predict_grf::run_with(&s, &opts, &floor)
                }
                Ok(_) => Err(statopt::Error::msg(
                    "predict-grf needs an AnalyzeTool setup with a StaticOptimization analysis",
                )),
                Err(e) => Err(e),
            };
            match run {
                Ok(p) => {
                    if !quiet {
                        let mut said = std::collections::HashSet::new();
                        for w in p
                            .summary
                            .warnings
                            .iter()
                            .filter(|w| said.insert(w.as_str()))
                        {
                            eprintln!("warning: {w}");
                        }
                        eprintln!("floor: {}", p.contacts.decision.reason);
                        eprintln!(
                            "foot contacts: {} points, floor at y = {:.4} m (points' contact levels {:.4} to {:.4} m), rising {:.2} deg along x and {:.2} deg along z, belt velocity ({:.3}, {:.3}) m/s",
                            p.contacts.points.len(),
                            p.contacts.floor_height,
                            p.contacts.points.iter().map(|q| q.contact_level).fold(f64::INFINITY, f64::min),
                            p.contacts.points.iter().map(|q| q.contact_level).fold(f64::NEG_INFINITY, f64::max),
                            p.contacts.floor_tilt_degrees().0,
                            p.contacts.floor_tilt_degrees().1,
                            p.contacts.belt_velocity.x,
                            p.contacts.belt_velocity.z
                        );
                        eprintln!(
                            "foot contacts: gait speed {:.2} m/s over the floor; a point sliding over it weakens from {:.2} m/s and carries nothing from {:.2} m/s (speed_weight, the walking gate scaled to gaits faster than {:.1} m/s)",
                            p.contacts.gait_speed,
                            p.contacts.parameters.speed_weight.0,
                            p.contacts.parameters.speed_weight.1,
                            p.contacts.parameters.speed_weight_gait_speed
                        );
                        for m in &p.metrics {
                            eprintln!(
                                "foot {} axis {}: rho {:.3}, RMSE {:.1} N = {:.2} % BW, peak error {:.1} N",
                                m.side, m.axis, m.rho, m.rmse_n, m.rmse_bw, m.peak_error_n
                            );
                        }
                        for st in &p.stance {
                            eprintln!("{}", st.summary());
                        }
                        for n in &p.summary.notes {
                            eprintln!("{n}");
                        }
                        for line in p.summary.report() {
                            eprintln!("{line}");
                        }
                    }
                    let failed = p.summary.failure_line();
                    if let Some(line) = &failed {
                        eprintln!("error: {line}");
                    }
                    if let Some(line) = &p.rejected {
                        eprintln!("error: {line}");
                    }
                    if failed.is_some() || p.rejected.is_some() {
                        ExitCode::from(tools::EXIT_FRAMES_FAILED)
                    } else {
                        ExitCode::SUCCESS
                    }
                }
                Err(e) => fail(e),
            }
        }
        Some(Command::KneeContact {
            setup,
            results_dir,
            joints,
            quiet,
        }) => {
            let opts = RunOptions {
                results_dir: results_dir.clone(),
                verbose: !quiet,
                ..Default::default()
            };
            match tools::knee_contact::run(setup, joints, &opts) {
                Ok(summary) => {
                    if !quiet {
                        for w in &summary.warnings {
                            eprintln!("warning: {w}");
                        }
                        for line in summary.report() {
                            eprintln!("{line}");
                        }
                    }
                    match summary.failure_line() {
                        Some(line) => {
                            eprintln!("error: {line}");
                            ExitCode::from(tools::EXIT_FRAMES_FAILED)
                        }
                        None => ExitCode::SUCCESS,
                    }
                }
                Err(e) => fail(e),
            }
        }
        Some(Command::EmgCompare {
            emg,
            activations,
            map,
            side,
            delay_ms,
            on_fraction,
            labels,
            output,
        }) => {
            use tools::emg_compare as ec;
            let map = match map {
                Some(f) => match ec::read_map(f) {
                    Ok(m) => m,
                    Err(e) => return fail(e),
                },
                None => ec::default_map(side.chars().next().unwrap_or('r')),
            };
            let opts = ec::Options {
                delay: 1e-3 * delay_ms,
                on_fraction: *on_fraction,
            };
            match ec::run(emg, activations, labels, &map, opts, output) {
                Ok((comparisons, files)) => {
                    let f =
                        |v: Option<f64>| v.map(|x| format!("{x:6.3}")).unwrap_or("   n/a".into());
                    for c in &comparisons {
                        println!(
                            "{} (EMG delay {delay_ms} ms, on at {:.0} % of peak)",
                            c.label,
                            100.0 * on_fraction
                        );
                        println!(
                            "  {:20} {:>6} {:>7} {:>9} {:>6}  muscles",
                            "channel", "r", "on/off", "best ms", "r best"
                        );
                        for ch in &c.channels {
                            println!(
                                "  {:20} {} {:7.3} {:>9} {}  {}",
                                ch.channel,
                                f(ch.r),
                                ch.on_off,
                                ch.best_delay_ms
                                    .map(|d| format!("{d:.0}"))
                                    .unwrap_or_default(),
                                f(ch.best_r),
                                ch.muscles.join(" ")
                            );
                        }
                        println!("  {:20} {} {:7.3}", "mean", f(c.mean_r()), c.mean_on_off());
                    }
                    for file in files {
                        eprintln!("wrote {}", file.display());
                    }
                    ExitCode::SUCCESS
                }
                Err(e) => fail(e),
            }
        }
        Some(Command::Scene { setup, output }) => match run_scene(setup, output) {
            Ok(()) => ExitCode::SUCCESS,
            Err(e) => fail(e),
        },
        Some(cmd @ Command::Motion { .. }) => match run_motion(cmd) {
            Ok(()) => ExitCode::SUCCESS,
            Err(e) => fail(e),
        },
        None if cli.run.check => {
            let Some(setup) = cli.run.setup.as_ref() else {
                return fail(statopt::Error::msg("no setup file given"));
            };
            // What the run would do: the same overrides.
            let opts = RunOptions {
                results_dir: cli.run.results_dir.clone(),
                reduce: cli.run.reduce,
                allow_unknown: cli.run.allow_unknown,
                ..Default::default()
            };
            let report = tools::check::run_with(setup, &opts);
            let mut said = std::collections::HashSet::new();
            for w in report.warnings.iter().filter(|w| said.insert(w.as_str())) {
                eprintln!("warning: {w}");
            }
            for e in &report.errors {
                eprintln!("error: {e}");
            }
            for n in &report.notes {
                eprintln!("note: {n}");
            }
            eprintln!(
                "check: {} problem(s), {} warning(s) in {}",
                report.errors.len(),
                said.len(),
                report.checked.join(", ")
            );
            if report.errors.is_empty() {
                ExitCode::SUCCESS
            } else {
                ExitCode::from(2)
            }
        }
        None => match run_setup(&cli.run) {
            Ok(summary) => {
                if !cli.run.quiet {
                    // Analyses of one setup share the motion: say each thing once.
                    let read_on = READ_ON.lock().unwrap().clone();
                    let mut said: std::collections::HashSet<&str> =
                        read_on.iter().map(String::as_str).collect();
                    for w in summary.warnings.iter().filter(|w| said.insert(w.as_str())) {
                        eprintln!("warning: {w}");
                    }
                    for n in &summary.notes {
                        eprintln!("{n}");
                    }
                    for line in summary.report() {
                        eprintln!("{line}");
                    }
                }
                // A stop and failures are said even with --quiet.
                if let Some((code, _)) = summary.stopped {
                    eprintln!("{}", summary.stopped_line().unwrap_or_default());
                    return ExitCode::from(code);
                }
                match summary.failure_line() {
                    Some(line) => {
                        eprintln!("error: {line}");
                        ExitCode::from(tools::EXIT_FRAMES_FAILED)
                    }
                    None => ExitCode::SUCCESS,
                }
            }
            Err(e) => fail(e),
        },
    }
}
