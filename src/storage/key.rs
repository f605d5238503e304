//! The typed key of every output a run writes: which run (setup,
//! analysis, place in a contact-weight sweep) and which table, log or
//! document ([`OutputKey`] = [`RunKey`] + [`OutputKind`]). Below the
//! pipeline so that `storage` may key what it keeps by it; the names made
//! from a key, its constructors and the lists of kinds are
//! `writers::names`' (`file_name`, the one function that makes output
//! names; `RunKey::analysis`, `OutputKind::SO_TABLES`).

/// A statistic over a contact-weight sweep's runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Stat {
    Mean,
    Min,
    Max,
}

/// Which run of a contact-weight sweep a file belongs to.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Sweep {
    /// The run of a single weight: no `w0_` part.
    Single,
    /// The run of weight w0 in a sweep.
    Weight(f64),
    /// A statistic over the sweep's runs: `mean`, `min` or `max`.
    Stat(Stat),
}

impl Eq for Sweep {}

impl std::hash::Hash for Sweep {
    fn hash<H: std::hash::Hasher>(&self, h: &mut H) {
        std::mem::discriminant(self).hash(h);
        match self {
            Sweep::Single => {}
            Sweep::Weight(w) => w.to_bits().hash(h),
            Sweep::Stat(s) => s.hash(h),
        }
    }
}

/// Position, velocity or acceleration (the kinematics analyses' tables).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Quantity {
    Pos,
    Vel,
    Acc,
}

/// Every kind of output file a run writes (the table, log or document,
/// without the run's part of the name).
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub enum OutputKind {
    // A static-optimization run (`<setup>_<analysis>_[w0_<tag>_]...`).
    Activation,
    Force,
    Diagnostics,
    ContactForces,
    ContactBodyForces,
    /// The contact forces as OpenSim external loads: the data (`.mot`) and
    /// its ExternalLoads document (`.xml`).
    ContactExternalLoads,
    ContactExternalLoadsXml,
    GeneralizedForcesBySource,
    MusclePower,
    /// The run's MCAP log.
    Log,
    /// `--reduce`'s record of what it dropped.
    Reduction,
    // A JointReaction analysis (coupled to a static optimization, or the
    // knee contact method's reactions, analysis `KneeContact`).
    ReactionLoads,
    KneeLoads,
    // A setup's own outputs (no analysis in the name).
    /// The knee contact method's compartment table.
    KneeContact,
    /// A setup's (or a study's) `<Metric>` values.
    Metrics,
    /// predict-grf: the predicted ground reactions (`.sto`), as OpenSim
    /// external loads (`.mot` and its `.xml`), the root residual, the foot
    /// contacts and the weak root residuals it adds (force sets), the
    /// comparison with measured loads (`.csv`).
    PredictedGrf,
    PredictedGrfMot,
    PredictedGrfXml,
    RootResidual,
    FootContacts,
    RootResiduals,
    GrfComparison,
    /// The figure comparing them (its stem: the plot writes `.png`, `.svg`).
    GrfComparisonFigure,
    /// The k-th force set of the setup without its root actuators.
    ForceSetWithoutRootResiduals(usize),
    /// A force sweep's table of candidates (`.csv`) and the folder of a
    /// candidate's tables (`<setup>_force_sweep/<candidate>`).
    ForceSweep,
    ForceSweepDir(String),
    /// A MuscleAnalysis table.
    MuscleAnalysis(MuscleTable),
    /// OpenSim's BodyKinematics: positions in ground, velocities and
    /// accelerations in ground or in the bodies' frames.
    BodyKinematics {
        quantity: Quantity,
        body_frame: bool,
    },
    /// OpenSim's PointKinematics of a point.
    PointKinematics {
        point: String,
        quantity: Quantity,
    },
    /// An InverseDynamicsTool's generalized forces, in the file its setup
    /// names (`<output_gen_force_file>`, OpenSim's name, kept as it is).
    InverseDynamics {
        file: String,
    },
}

/// A MuscleAnalysis table.
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub enum MuscleTable {
    Length,
    LengtheningSpeed,
    MaxActiveFiberForceRigidTendon,
    PassiveFiberForceRigidTendon,
    /// The moment arms about a coordinate.
    MomentArm(String),
}

/// Which run an output belongs to: its setup, its analysis (None: the
/// setup's own outputs) and its place in a contact-weight sweep.
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub struct RunKey {
    pub setup: String,
    pub analysis: Option<String>,
    pub sweep: Sweep,
}

/// One output file: its run and its kind.
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub struct OutputKey {
    pub run: RunKey,
    pub kind: OutputKind,
}
