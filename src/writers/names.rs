//! The names of every output file a run writes, made in one place: a typed
//! key ([`OutputKey`]: which run — setup, analysis, w0 — and which table,
//! [`OutputKind`]) and one function that makes its file name,
//! [`file_name`]. A run's tables are `<setup>_<analysis>_[w0_<tag>_]<kind>`
//! (`leg_extension_cam1_SO_w0_500_force.sto`,
//! `..._JR_w0_mean_KneeLoads.sto`); a setup's own tables carry no analysis
//! (`<setup>_[w0_<tag>_]KneeContact.sto`, `<setup>_predicted_grf.sto`). A
//! run of one contact weight carries no `w0_` part; a sweep's runs carry
//! their weight's tag ([`w0_tag`]) and its statistics the tags `mean`,
//! `min`, `max`.
//!
//! Nothing parses a name back: a file a user names (a study's figure
//! references, a force sweep's metrics) is looked up among the names of the
//! keys a plan writes ([`find`]), and the Python package gets keys, names and
//! w0 values through its binding.

pub use crate::storage::key::{MuscleTable, OutputKey, OutputKind, Quantity, RunKey, Stat, Sweep};

impl Stat {
    /// Every statistic, in the order the tables are written.
    pub const ALL: [Stat; 3] = [Stat::Mean, Stat::Min, Stat::Max];

    /// Its tag in file names: `mean`, `min`, `max`.
    pub fn as_str(self) -> &'static str {
        match self {
            Stat::Mean => "mean",
            Stat::Min => "min",
            Stat::Max => "max",
        }
    }
}

/// The tags of a sweep's statistics tables.
pub const SWEEP_STATS: [&str; 3] = ["mean", "min", "max"];

impl Sweep {
    /// The run of weight `w0`: [`Sweep::Weight`] in a sweep of several
    /// weights, [`Sweep::Single`] otherwise.
    pub fn of(w0: f64, sweep: bool) -> Sweep {
        if sweep {
            Sweep::Weight(w0)
        } else {
            Sweep::Single
        }
    }

    /// The tag file names carry (`500`, `mean`), None for a single weight.
    pub fn tag(self) -> Option<String> {
        match self {
            Sweep::Single => None,
            Sweep::Weight(w0) => Some(w0_tag(w0)),
            Sweep::Stat(s) => Some(s.as_str().to_string()),
        }
    }

    /// The sweeps a run of `weights` writes: each weight and the three
    /// statistics, or the single run.
    pub fn all(weights: &[f64]) -> Vec<Sweep> {
        if weights.len() > 1 {
            let mut v: Vec<Sweep> = weights.iter().map(|w| Sweep::Weight(*w)).collect();
            v.extend(Stat::ALL.map(Sweep::Stat));
            v
        } else {
            vec![Sweep::Single]
        }
    }
}

/// A contact weight as file names carry it: `500`, `0.001`, `1e6`.
pub fn w0_tag(w0: f64) -> String {
    let t = format!("{w0}");
    if t.len() <= 8 {
        t
    } else {
        format!("{w0:e}")
    }
}

impl Quantity {
    pub const ALL: [Quantity; 3] = [Quantity::Pos, Quantity::Vel, Quantity::Acc];

    fn as_str(self) -> &'static str {
        match self {
            Quantity::Pos => "pos",
            Quantity::Vel => "vel",
            Quantity::Acc => "acc",
        }
    }
}

impl OutputKind {
    /// The tables of a static-optimization run that hold one row per
    /// frame, as a sweep's statistics and a force sweep's metrics read them
    /// (the contact tables only with contacts).
    pub const SO_TABLES: [OutputKind; 7] = [
        OutputKind::Activation,
        OutputKind::Force,
        OutputKind::Diagnostics,
        OutputKind::ContactForces,
        OutputKind::ContactBodyForces,
        OutputKind::GeneralizedForcesBySource,
        OutputKind::MusclePower,
    ];

    /// The tables a w0 sweep writes its statistics of.
    pub const SWEEP_TABLES: [OutputKind; 6] = [
        OutputKind::Activation,
        OutputKind::Force,
        OutputKind::ContactForces,
        OutputKind::ContactBodyForces,
        OutputKind::GeneralizedForcesBySource,
        OutputKind::MusclePower,
    ];

    /// Whether the run writes it only with contacts.
    pub fn needs_contacts(&self) -> bool {
        matches!(
            self,
            OutputKind::ContactForces
                | OutputKind::ContactBodyForces
                | OutputKind::ContactExternalLoads
                | OutputKind::ContactExternalLoadsXml
        )
    }

    /// The kind's part of the file name, extension included
    /// (`activation.sto`, `log.mcap`, `MomentArm_knee_angle_r.sto`).
    fn suffix(&self) -> String {
        match self {
            OutputKind::Log => "log.mcap".into(),
            OutputKind::Reduction => "reduction.txt".into(),
            OutputKind::ContactExternalLoads => "ContactExternalLoads.mot".into(),
            OutputKind::ContactExternalLoadsXml => "ContactExternalLoads.xml".into(),
            OutputKind::Metrics => "metrics.csv".into(),
            OutputKind::PredictedGrfMot => "predicted_grf.mot".into(),
            OutputKind::PredictedGrfXml => "predicted_grf.xml".into(),
            OutputKind::FootContacts => "foot_contacts.xml".into(),
            OutputKind::RootResiduals => "root_residuals.xml".into(),
            OutputKind::GrfComparison => "grf_comparison.csv".into(),
            OutputKind::GrfComparisonFigure => "grf_comparison".into(),
            OutputKind::ForceSetWithoutRootResiduals(k) => {
                format!("force_set_{k}_without_root_residuals.xml")
            }
            OutputKind::ForceSweep => "force_sweep.csv".into(),
            OutputKind::ForceSweepDir(c) => format!("force_sweep/{c}"),
            k => format!("{}.sto", k.table()),
        }
    }

    /// The table's name as results and the Python package call it, its file
    /// name's end without the extension (`activation`, `KneeLoads`,
    /// `MomentArm_knee_angle_r`, `BodyKinematics_pos_global`).
    pub fn table(&self) -> String {
        match self {
            OutputKind::Activation => "activation".into(),
            OutputKind::Force => "force".into(),
            OutputKind::Diagnostics => "diagnostics".into(),
            OutputKind::ContactForces => "ContactForces".into(),
            OutputKind::ContactBodyForces => "ContactBodyForces".into(),
            OutputKind::ContactExternalLoads | OutputKind::ContactExternalLoadsXml => {
                "ContactExternalLoads".into()
            }
            OutputKind::GeneralizedForcesBySource => "GeneralizedForcesBySource".into(),
            OutputKind::MusclePower => "MusclePower".into(),
            OutputKind::Log => "log".into(),
            OutputKind::Reduction => "reduction".into(),
            OutputKind::ReactionLoads => "ReactionLoads".into(),
            OutputKind::KneeLoads => "KneeLoads".into(),
            OutputKind::KneeContact => "KneeContact".into(),
            OutputKind::Metrics => "metrics".into(),
            OutputKind::PredictedGrf
            | OutputKind::PredictedGrfMot
            | OutputKind::PredictedGrfXml => "predicted_grf".into(),
            OutputKind::RootResidual => "root_residual".into(),
            OutputKind::FootContacts => "foot_contacts".into(),
            OutputKind::RootResiduals => "root_residuals".into(),
            OutputKind::GrfComparison | OutputKind::GrfComparisonFigure => "grf_comparison".into(),
            OutputKind::ForceSetWithoutRootResiduals(k) => {
                format!("force_set_{k}_without_root_residuals")
            }
            OutputKind::ForceSweep | OutputKind::ForceSweepDir(_) => "force_sweep".into(),
            OutputKind::MuscleAnalysis(t) => t.name(),
            OutputKind::BodyKinematics {
                quantity,
                body_frame,
            } => {
                let frame = if *body_frame && *quantity != Quantity::Pos {
                    "bodyLocal"
                } else {
                    "global"
                };
                format!("{}_{frame}", quantity.as_str())
            }
            OutputKind::PointKinematics { point, quantity } => {
                format!("{point}_{}", quantity.as_str())
            }
            OutputKind::InverseDynamics { .. } => "inverse_dynamics".into(),
        }
    }
}

impl MuscleTable {
    /// The tables every MuscleAnalysis writes, before its moment arms.
    pub const ALWAYS: [MuscleTable; 4] = [
        MuscleTable::Length,
        MuscleTable::LengtheningSpeed,
        MuscleTable::MaxActiveFiberForceRigidTendon,
        MuscleTable::PassiveFiberForceRigidTendon,
    ];

    /// Its name: the file name's end and the table's name in its header
    /// (OpenSim's).
    pub fn name(&self) -> String {
        match self {
            MuscleTable::Length => "Length".into(),
            MuscleTable::LengtheningSpeed => "LengtheningSpeed".into(),
            MuscleTable::MaxActiveFiberForceRigidTendon => "MaxActiveFiberForceRigidTendon".into(),
            MuscleTable::PassiveFiberForceRigidTendon => "PassiveFiberForceRigidTendon".into(),
            MuscleTable::MomentArm(c) => format!("MomentArm_{c}"),
        }
    }
}

impl RunKey {
    /// The run of analysis `analysis` of setup `setup`.
    pub fn analysis(setup: &str, analysis: &str, sweep: Sweep) -> RunKey {
        RunKey {
            setup: setup.to_string(),
            analysis: Some(analysis.to_string()),
            sweep,
        }
    }

    /// The outputs of setup `setup` itself.
    pub fn setup(setup: &str, sweep: Sweep) -> RunKey {
        RunKey {
            setup: setup.to_string(),
            analysis: None,
            sweep,
        }
    }

    /// The same run at another place of the sweep.
    pub fn with_sweep(&self, sweep: Sweep) -> RunKey {
        RunKey {
            sweep,
            ..self.clone()
        }
    }

    /// The key of its output `kind`.
    pub fn key(&self, kind: OutputKind) -> OutputKey {
        OutputKey {
            run: self.clone(),
            kind,
        }
    }

    /// The file name of its output `kind` ([`file_name`]).
    pub fn file(&self, kind: OutputKind) -> String {
        file_name(&self.key(kind))
    }

    /// The run's name in reports: `<setup>_<analysis>`, without w0.
    pub fn label(&self) -> String {
        match &self.analysis {
            Some(a) => format!("{}_{a}", self.setup),
            None => self.setup.clone(),
        }
    }
}

/// The file name of an output: `<setup>_[<analysis>_][w0_<tag>_]<kind>`,
/// with its extension. The one function that makes output names; it tells
/// the run's capture which key the name is made from
/// (`storage::results::name`), so that the run keeps the output under its
/// typed key.
pub fn file_name(key: &OutputKey) -> String {
    if let OutputKind::InverseDynamics { file } = &key.kind {
        // OpenSim's InverseDynamicsTool writes the file its setup names,
        // with no part of the run in front; the capture learns the key by
        // the name's last part (the file in the results folder).
        let last = std::path::Path::new(file)
            .file_name()
            .and_then(|n| n.to_str())
            .unwrap_or(file);
        crate::storage::results::name(last, key);
        return file.clone();
    }
    let r = &key.run;
    let mut name = r.setup.clone();
    name.push('_');
    if let Some(a) = &r.analysis {
        name.push_str(a);
        name.push('_');
    }
    if let Some(tag) = r.sweep.tag() {
        name.push_str("w0_");
        name.push_str(&tag);
        name.push('_');
    }
    name.push_str(&key.kind.suffix());
    crate::storage::results::name(&name, key);
    name
}

/// The key among `keys` whose file name is `file` (a file name, no
/// folder): how a name a user wrote is known, by the names the plan makes,
/// never by taking it apart.
pub fn find<'a>(file: &str, keys: &'a [OutputKey]) -> Option<&'a OutputKey> {
    keys.iter().find(|k| file_name(k) == file)
}

/// The outputs a setup's plan writes, as keys: what a file a user names
/// (a figure's or a metric's table) is looked up among. Tables the model
/// decides (the contact tables, written only with contacts) are counted
/// in; a MuscleAnalysis of `all` coordinates writes a moment-arm table per
/// coordinate of the model, which the plan does not know: any coordinate's
/// name is taken for those.
#[derive(Debug, Clone, Default)]
pub struct Planned {
    pub keys: Vec<OutputKey>,
    /// MuscleAnalysis runs of every coordinate.
    any_moment_arm: Vec<RunKey>,
}

impl Planned {
    /// The places in a w0 sweep that setup `setup`'s runs may carry: a
    /// sweep's runs and statistics, and the single run too (a model without
    /// contacts is solved once, without w0 in the names).
    pub fn sweeps(setup: &crate::parse::setup::AnalyzeSetup) -> Vec<Sweep> {
        let weights: Vec<f64> = setup
            .static_optimization()
            .map(|so| so.contact_weights.clone())
            .unwrap_or_default();
        let mut sweeps = Sweep::all(&weights);
        if !sweeps.contains(&Sweep::Single) {
            sweeps.push(Sweep::Single);
        }
        sweeps
    }

    /// The outputs of setup `setup`'s analyses that are on.
    pub fn of(setup: &crate::parse::setup::AnalyzeSetup) -> Planned {
        use crate::parse::analyses::KneeSelection;
        use crate::parse::kinematics::KinematicsSetup;
        use crate::parse::setup::Analysis;
        let name = setup.name.as_str();
        let sweeps = Planned::sweeps(setup);
        let mut p = Planned::default();
        let own = RunKey::setup(name, Sweep::Single);
        p.keys.push(own.key(OutputKind::Metrics));
        for a in setup.analyses.iter().filter(|a| a.common().on) {
            let analysis = a.common().name.as_str();
            let run = |sweep| RunKey::analysis(name, analysis, sweep);
            match a {
                Analysis::StaticOptimization(so) => {
                    for &sweep in &sweeps {
                        let stat = matches!(sweep, Sweep::Stat(_));
                        let kinds: &[OutputKind] = if stat {
                            &OutputKind::SWEEP_TABLES
                        } else {
                            &OutputKind::SO_TABLES
                        };
                        p.keys
                            .extend(kinds.iter().map(|k| run(sweep).key(k.clone())));
                        if !stat {
                            p.keys.extend(
                                [
                                    OutputKind::ContactExternalLoads,
                                    OutputKind::ContactExternalLoadsXml,
                                    OutputKind::Log,
                                ]
                                .map(|k| run(sweep).key(k)),
                            );
                        }
                        if so.knee_contact != KneeSelection::Off {
                            p.keys
                                .push(RunKey::setup(name, sweep).key(OutputKind::KneeContact));
                            if !stat {
                                p.keys.push(
                                    RunKey::analysis(name, "KneeContact", sweep)
                                        .key(OutputKind::ReactionLoads),
                                );
                            }
                        }
                    }
                    p.keys.push(run(Sweep::Single).key(OutputKind::Reduction));
                    p.keys.extend(
                        [
                            OutputKind::FootContacts,
                            OutputKind::RootResiduals,
                            OutputKind::RootResidual,
                            OutputKind::PredictedGrf,
                            OutputKind::PredictedGrfMot,
                            OutputKind::PredictedGrfXml,
                            OutputKind::GrfComparison,
                        ]
                        .map(|k| own.key(k)),
                    );
                }
                Analysis::JointReaction(jr) => {
                    let places: &[Sweep] = if jr.forces_file.is_some() {
                        &[Sweep::Single]
                    } else {
                        &sweeps
                    };
                    for &sweep in places {
                        p.keys.push(run(sweep).key(OutputKind::ReactionLoads));
                        if jr.knee_loads {
                            p.keys.push(run(sweep).key(OutputKind::KneeLoads));
                        }
                    }
                }
                Analysis::MuscleAnalysis(ma) => {
                    let r = run(Sweep::Single);
                    p.keys
                        .extend(MuscleTable::ALWAYS.map(|t| r.key(OutputKind::MuscleAnalysis(t))));
                    let coords = &ma.moment_arm_coordinate_list;
                    if coords.iter().any(|c| c.eq_ignore_ascii_case("all")) {
                        p.any_moment_arm.push(r);
                    } else {
                        p.keys.extend(coords.iter().map(|c| {
                            r.key(OutputKind::MuscleAnalysis(MuscleTable::MomentArm(
                                c.clone(),
                            )))
                        }));
                    }
                }
                Analysis::Kinematics(k) => {
                    let r = run(Sweep::Single);
                    p.keys.extend(Quantity::ALL.map(|quantity| {
                        r.key(match &**k {
                            KinematicsSetup::Body(b) => OutputKind::BodyKinematics {
                                quantity,
                                body_frame: b.express_in_body_frame,
                            },
                            KinematicsSetup::Point(pk) => OutputKind::PointKinematics {
                                point: pk.point_name.clone(),
                                quantity,
                            },
                        })
                    }));
                }
                Analysis::Unsupported { .. } => {}
            }
        }
        p
    }

    /// The key whose file name is `file`, if the plan writes it.
    pub fn find(&self, file: &str) -> Option<OutputKey> {
        if let Some(k) = find(file, &self.keys) {
            return Some(k.clone());
        }
        // A moment-arm table of any coordinate: its name made with a
        // placeholder coordinate, the file's coordinate read in its place.
        const HOLE: &str = "\u{1}";
        self.any_moment_arm.iter().find_map(|run| {
            let kind = |c: String| OutputKind::MuscleAnalysis(MuscleTable::MomentArm(c));
            let probe = run.file(kind(HOLE.into()));
            let (head, tail) = probe.split_once(HOLE)?;
            let coordinate = file.strip_prefix(head)?.strip_suffix(tail)?;
            (!coordinate.is_empty()).then(|| run.key(kind(coordinate.into())))
        })
    }

    /// The w0 tags the plan's names carry (`1`, `500`, `mean`, ...), the
    /// weights first; empty without a sweep.
    pub fn w0_tags(setup: &crate::parse::setup::AnalyzeSetup) -> Vec<String> {
        let weights: Vec<f64> = setup
            .static_optimization()
            .map(|so| so.contact_weights.clone())
            .unwrap_or_default();
        Sweep::all(&weights)
            .into_iter()
            .filter_map(Sweep::tag)
            .collect()
    }
}

/// The w0 tag a file name a user wrote carries (`..._w0_500_force.sto` →
/// `500`), if any: only to word the error about a name that is none of the
/// plan's ([`find`] decides which names are).
pub fn w0_tag_in(file: &str) -> Option<&str> {
    let k = file.find("_w0_")?;
    file[k + 4..].split('_').next().filter(|t| !t.is_empty())
}

/// The three files of OpenSim's BodyKinematics analysis `analysis` of
/// setup `setup`: `<setup>_<analysis>_pos_global.sto`, `_vel_global.sto`,
/// `_acc_global.sto` (`_bodyLocal` for the velocities and accelerations
/// when they are expressed in the bodies' frames).
pub fn body_kinematics_files(setup: &str, analysis: &str, body_frame: bool) -> [String; 3] {
    let run = RunKey::analysis(setup, analysis, Sweep::Single);
    Quantity::ALL.map(|quantity| {
        run.file(OutputKind::BodyKinematics {
            quantity,
            body_frame,
        })
    })
}

/// The three files of OpenSim's PointKinematics analysis `analysis` of
/// setup `setup`: `<setup>_<analysis>_<point>_pos.sto`, `_vel.sto`, `_acc.sto`.
pub fn point_kinematics_files(setup: &str, analysis: &str, point: &str) -> [String; 3] {
    let run = RunKey::analysis(setup, analysis, Sweep::Single);
    Quantity::ALL.map(|quantity| {
        run.file(OutputKind::PointKinematics {
            point: point.to_string(),
            quantity,
        })
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A run keeps an output under the typed key its name was made from
    /// (`storage::results::OutputId`): found by key in its folder, and by
    /// its path; a consumer that wanted its path before the name was made
    /// (a JointReaction's `<forces_file>`) still finds it; a file no key
    /// names is kept by its path.
    #[test]
    fn a_run_keeps_its_outputs_under_their_typed_keys() {
        use crate::storage::results::{get, want, Capture, Output};
        let tmp = crate::test_dir::TempDir::new("names_typed_keys");
        let dir = tmp.path();
        // A capture that writes files keeps only what is wanted.
        let c = Capture::new(Some(dir));
        let table = |p: &std::path::Path| {
            let mut w = crate::storage::StoWriter::create(p, "t", "", &["a".to_string()], 8, false)
                .unwrap();
            w.write_row(0.0, &[0.5]).unwrap();
            w.finish().unwrap();
        };
        let run = RunKey::analysis("setup", "SO", Sweep::Weight(500.0));
        // Wanted by its path before any name was made from its key.
        let early = dir.join("setup_SO_w0_500_activation.sto");
        want(&early);
        let (force, activation) = (run.key(OutputKind::Force), run.key(OutputKind::Activation));
        let forces = dir.join(file_name(&force));
        want(&forces);
        let other = dir.join("figure_data.sto");
        want(&other);
        table(&forces);
        table(&dir.join(file_name(&activation)));
        table(&other);
        table(&dir.join(file_name(&run.key(OutputKind::Diagnostics))));
        assert_eq!(c.kept().0, 3, "{:?}", c.outputs());
        for (key, path) in [(&force, &forces), (&activation, &early)] {
            let by_key = c.output(dir, key).expect("kept by its key");
            let by_path = get(path).expect("kept by its path");
            assert!(matches!(
                (&by_key, &by_path),
                (Output::Table(a), Output::Table(b)) if std::sync::Arc::ptr_eq(a, b)
            ));
        }
        assert!(get(&other).is_some());
        // Not wanted: in its file only. Another folder: not this output.
        assert!(c.output(dir, &run.key(OutputKind::Diagnostics)).is_none());
        assert!(c.output(&dir.join("sub"), &force).is_none());
    }

    /// Every kind, with the name it had before the kinds were typed (the
    /// names the shipped setups' outputs carry, byte for byte).
    fn every_kind() -> Vec<(OutputKind, &'static str)> {
        use OutputKind::*;
        vec![
            (Activation, "activation.sto"),
            (Force, "force.sto"),
            (Diagnostics, "diagnostics.sto"),
            (ContactForces, "ContactForces.sto"),
            (ContactBodyForces, "ContactBodyForces.sto"),
            (ContactExternalLoads, "ContactExternalLoads.mot"),
            (ContactExternalLoadsXml, "ContactExternalLoads.xml"),
            (GeneralizedForcesBySource, "GeneralizedForcesBySource.sto"),
            (MusclePower, "MusclePower.sto"),
            (Log, "log.mcap"),
            (Reduction, "reduction.txt"),
            (ReactionLoads, "ReactionLoads.sto"),
            (KneeLoads, "KneeLoads.sto"),
            (KneeContact, "KneeContact.sto"),
            (Metrics, "metrics.csv"),
            (PredictedGrf, "predicted_grf.sto"),
            (PredictedGrfMot, "predicted_grf.mot"),
            (PredictedGrfXml, "predicted_grf.xml"),
            (RootResidual, "root_residual.sto"),
            (FootContacts, "foot_contacts.xml"),
            (RootResiduals, "root_residuals.xml"),
            (GrfComparison, "grf_comparison.csv"),
            (GrfComparisonFigure, "grf_comparison"),
            (
                ForceSetWithoutRootResiduals(1),
                "force_set_1_without_root_residuals.xml",
            ),
            (ForceSweep, "force_sweep.csv"),
            (ForceSweepDir("c7".into()), "force_sweep/c7"),
            (MuscleAnalysis(MuscleTable::Length), "Length.sto"),
            (
                MuscleAnalysis(MuscleTable::LengtheningSpeed),
                "LengtheningSpeed.sto",
            ),
            (
                MuscleAnalysis(MuscleTable::MaxActiveFiberForceRigidTendon),
                "MaxActiveFiberForceRigidTendon.sto",
            ),
            (
                MuscleAnalysis(MuscleTable::PassiveFiberForceRigidTendon),
                "PassiveFiberForceRigidTendon.sto",
            ),
            (
                MuscleAnalysis(MuscleTable::MomentArm("knee_angle_r".into())),
                "MomentArm_knee_angle_r.sto",
            ),
            (
                BodyKinematics {
                    quantity: Quantity::Pos,
                    body_frame: true,
                },
                "pos_global.sto",
            ),
            (
                BodyKinematics {
                    quantity: Quantity::Vel,
                    body_frame: true,
                },
                "vel_bodyLocal.sto",
            ),
            (
                BodyKinematics {
                    quantity: Quantity::Acc,
                    body_frame: false,
                },
                "acc_global.sto",
            ),
            (
                PointKinematics {
                    point: "pad".into(),
                    quantity: Quantity::Vel,
                },
                "pad_vel.sto",
            ),
        ]
    }

    /// An InverseDynamicsTool's table keeps the name its setup gives it
    /// (OpenSim's `<output_gen_force_file>`), and the run still knows it by
    /// its typed key, so the Python package need not go by the file's stem.
    #[test]
    fn an_inverse_dynamics_table_keeps_its_setups_name_and_has_a_key() {
        use crate::storage::results::Capture;
        let c = Capture::in_memory();
        let dir = c.root().unwrap().to_path_buf();
        let key = RunKey::setup("pendulum", Sweep::Single).key(OutputKind::InverseDynamics {
            file: "id_out.sto".into(),
        });
        assert_eq!(file_name(&key), "id_out.sto");
        assert_eq!(key.kind.table(), "inverse_dynamics");
        crate::storage::results::write(&dir.join("id_out.sto"), b"x".to_vec()).unwrap();
        assert_eq!(c.key_of(&dir.join("id_out.sto")), Some(key.clone()));
        // A name with a folder in it: known by its last part, in that folder.
        let nested = RunKey::setup("p2", Sweep::Single).key(OutputKind::InverseDynamics {
            file: "sub/forces.sto".into(),
        });
        assert_eq!(file_name(&nested), "sub/forces.sto");
        assert_eq!(c.key_of(&dir.join("sub/forces.sto")), Some(nested));
        assert_eq!(c.key_of(&dir.join("other.sto")), None);
    }

    #[test]
    fn w0_tags() {
        assert_eq!(w0_tag(500.0), "500");
        assert_eq!(w0_tag(0.001), "0.001");
        assert_eq!(w0_tag(1e6), "1000000");
        assert_eq!(w0_tag(1e9), "1e9");
    }

    /// Every kind's name, in every run and sweep, is the name the run
    /// wrote before the kinds were typed, and is found back as its key
    /// among all the others' (no two keys share a name).
    #[test]
    fn every_output_name_round_trips_and_is_todays() {
        let sweeps = [
            (Sweep::Single, ""),
            (Sweep::Weight(500.0), "w0_500_"),
            (Sweep::Weight(0.5), "w0_0.5_"),
            (Sweep::Weight(1e9), "w0_1e9_"),
            (Sweep::Stat(Stat::Mean), "w0_mean_"),
            (Sweep::Stat(Stat::Min), "w0_min_"),
            (Sweep::Stat(Stat::Max), "w0_max_"),
        ];
        let mut keys = Vec::new();
        let mut expected = Vec::new();
        for (kind, end) in every_kind() {
            for (sweep, tag) in sweeps {
                for (analysis, part) in [(Some("SO"), "SO_"), (Some("JR"), "JR_"), (None, "")] {
                    let run = RunKey {
                        setup: "cam1".into(),
                        analysis: analysis.map(String::from),
                        sweep,
                    };
                    keys.push(run.key(kind.clone()));
                    expected.push(format!("cam1_{part}{tag}{end}"));
                }
            }
        }
        for (key, name) in keys.iter().zip(&expected) {
            assert_eq!(&file_name(key), name);
            assert_eq!(find(name, &keys), Some(key), "{name}");
        }
        // Names of today's outputs, literally.
        let so = RunKey::analysis("leg_extension_cam1", "SO", Sweep::Weight(500.0));
        assert_eq!(
            so.file(OutputKind::Force),
            "leg_extension_cam1_SO_w0_500_force.sto"
        );
        assert_eq!(
            RunKey::analysis("x", "JR", Sweep::Stat(Stat::Mean)).file(OutputKind::KneeLoads),
            "x_JR_w0_mean_KneeLoads.sto"
        );
        assert_eq!(
            RunKey::setup("x", Sweep::Weight(1.0)).file(OutputKind::KneeContact),
            "x_w0_1_KneeContact.sto"
        );
        assert_eq!(
            RunKey::analysis("x", "KneeContact", Sweep::Weight(1.0))
                .file(OutputKind::ReactionLoads),
            "x_KneeContact_w0_1_ReactionLoads.sto"
        );
        assert_eq!(
            RunKey::setup("subject01", Sweep::Single).file(OutputKind::PredictedGrf),
            "subject01_predicted_grf.sto"
        );
        assert_eq!(
            body_kinematics_files("s", "BK", false),
            [
                "s_BK_pos_global.sto",
                "s_BK_vel_global.sto",
                "s_BK_acc_global.sto"
            ]
        );
        assert_eq!(
            point_kinematics_files("s", "PK", "pad"),
            ["s_PK_pad_pos.sto", "s_PK_pad_vel.sto", "s_PK_pad_acc.sto"]
        );
        assert_eq!(find("cam1_SO_w0_7_force.sto", &keys), None);
        assert_eq!(
            SWEEP_STATS,
            Stat::ALL.map(Stat::as_str),
            "the statistics' tags"
        );
    }
}
