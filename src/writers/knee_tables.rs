//! The knee tables of a static-optimization pass as a sink of its frame
//! stream (`frame::so_loop`): each JointReaction's
//! `<reaction table prefix>KneeLoads.sto` (`reactions::knee_loads`;
//! `tools::knee_loads` documents the frame and signs) and the knee contact
//! method's `<name>_KneeContact.sto` (`reactions::knee_contact`), per run
//! (w0), and in a w0 sweep their mean, minimum and maximum over the runs
//! (`writers::sweep_statistics`). Each frame's reactions are taken as their
//! ReactionLoads table prints them (`storage::results::as_printed`), so
//! the tables are the ones made from the ReactionLoads files, bit for bit;
//! no table is kept or read for them. A resumed run feeds the sink from
//! its read tables ([`KneeTables::push_rows`]).

use std::path::{Path, PathBuf};

use crate::dynamics::{kinematics, Data};
use crate::error::Result;
use crate::frame::knee_contact::Knee;
use crate::model::Model;
use crate::reactions::knee_loads::Side;
use crate::storage::results::as_printed;
use crate::storage::StoWriter;
use crate::writers::sweep_statistics::{Source, SweepStatistics};

/// Header text of a KneeLoads table.
pub const LOADS_DESCRIPTION: &str = "Knee loads per side (statopt, docs/leg_extension_results.md): knee_flexion in degrees (flexion positive); tibiofemoral reaction on the tibia in the tibia frame: tf_compression = -Fy (along the tibial long axis, compression positive), tf_shear = +Fx (anterior, perpendicular to the long axis: PCL-type positive, ACL-type negative); pf_compression = magnitude of the patellofemoral reaction on the patella (absent without a patella body). Units N.";

/// Header text of a KneeContact table.
pub const CONTACT_DESCRIPTION: &str = "Knee contact forces of statopt's knee contact method (docs/knee_contact.md): per knee, flexion in degrees (flexion positive); total_N = magnitude of the tibiofemoral reaction on the tibia; medial_N, lateral_N = the compartments' compressive loads (along the tibial long axis, balancing the frontal-plane moment at 40 mm apart). Units N.";

/// What a knee table is made of.
pub enum KneeKind {
    /// KneeLoads of the joint reactions `reaction` (their index in a
    /// frame's reaction rows), with both sides' columns.
    Loads {
        reaction: usize,
        sides: Box<[Side; 2]>,
        patella: bool,
    },
    /// KneeContact from the knee contact method's reactions `reaction`
    /// (`reactions::knee_contact::reaction_specs`).
    Contact { reaction: usize },
}

impl KneeKind {
    fn reaction(&self) -> usize {
        match self {
            KneeKind::Loads { reaction, .. } | KneeKind::Contact { reaction } => *reaction,
        }
    }
}

/// One kind of knee table: per run its path (and writer once opened).
struct Table {
    kind: KneeKind,
    labels: Vec<String>,
    paths: Vec<PathBuf>,
    writers: Vec<StoWriter>,
    /// Its statistics' index in [`KneeTables::stats`] (a sweep).
    stats: Option<usize>,
    /// This frame's row per run.
    rows: Vec<Vec<f64>>,
}

/// The knee tables of a pass, fed each frame's reaction rows.
pub struct KneeTables<'a> {
    model: &'a Model,
    knees: &'a [Knee],
    setup_file: PathBuf,
    precision: usize,
    data: Data,
    tables: Vec<Table>,
    stats: Option<SweepStatistics>,
    printed: Vec<f64>,
}

impl<'a> KneeTables<'a> {
    /// The sink of a pass of `runs` runs (weights `weights`, one per run):
    /// a sweep (more than one) writes statistics too.
    pub fn new(
        model: &'a Model,
        knees: &'a [Knee],
        setup_file: &Path,
        weights: &[f64],
        precision: usize,
    ) -> KneeTables<'a> {
        let stats =
            (weights.len() > 1).then(|| SweepStatistics::new(setup_file, weights, 0, precision));
        KneeTables {
            model,
            knees,
            setup_file: setup_file.to_path_buf(),
            precision,
            data: Data::new(model),
            tables: Vec::new(),
            stats,
            printed: Vec::new(),
        }
    }

    /// A table of `kind`, at `paths` (one per run), its statistics at
    /// `stat_path` (a sweep; `writers::names`).
    pub fn add(
        &mut self,
        kind: KneeKind,
        paths: Vec<PathBuf>,
        stat_path: &dyn Fn(crate::writers::names::Stat) -> PathBuf,
        stat_kind: &str,
    ) {
        let labels = match &kind {
            KneeKind::Loads { patella, .. } => crate::reactions::knee_loads::labels(*patella),
            KneeKind::Contact { .. } => crate::reactions::knee_contact::labels(self.knees),
        };
        let stats = self
            .stats
            .as_mut()
            .map(|s| s.add(Source::Given, stat_kind, &labels, stat_path));
        let n = paths.len();
        self.tables.push(Table {
            kind,
            labels,
            paths,
            writers: Vec::new(),
            stats,
            rows: vec![Vec::new(); n],
        });
    }

    /// The joint reactions (indices in a frame's reaction rows) its tables
    /// are made from.
    pub fn reactions(&self) -> Vec<usize> {
        self.tables.iter().map(|t| t.kind.reaction()).collect()
    }

    /// Whether it has any table.
    pub fn is_empty(&self) -> bool {
        self.tables.is_empty()
    }

    fn open(&mut self) -> Result<()> {
        for t in self.tables.iter_mut().filter(|t| t.writers.is_empty()) {
            let (name, desc) = match t.kind {
                KneeKind::Loads { .. } => ("Knee loads", LOADS_DESCRIPTION),
                KneeKind::Contact { .. } => ("Knee contact", CONTACT_DESCRIPTION),
            };
            for path in &t.paths {
                let mut w = StoWriter::create_for_setup(
                    &self.setup_file,
                    path,
                    name,
                    desc,
                    &t.labels,
                    self.precision,
                    false,
                )?;
                w.batch_rows(32, std::time::Duration::from_millis(200));
                t.writers.push(w);
            }
        }
        Ok(())
    }

    /// One frame's outputs, one per run.
    pub fn push(&mut self, results: &[crate::frame::so_loop::FrameOutput]) -> Result<()> {
        let Some((first, _)) = results.first() else {
            return Ok(());
        };
        let reactions: Vec<&[Vec<f64>]> = results.iter().map(|(_, r)| r.as_slice()).collect();
        self.push_rows(first.time, &first.q, &reactions)
    }

    /// One frame at `time` and positions `q`: per run, its joint
    /// reactions' rows (indexed as [`KneeKind`]'s `reaction`).
    pub fn push_rows(&mut self, time: f64, q: &[f64], reactions: &[&[Vec<f64>]]) -> Result<()> {
        if self.tables.first().is_some_and(|t| t.writers.is_empty()) {
            self.open()?;
        }
        let p = self.precision;
        self.data.q.copy_from_slice(q);
        self.data.u.iter_mut().for_each(|x| *x = 0.0);
        kinematics::full(self.model, &mut self.data);
        let t = as_printed(time, p);
        for table in &mut self.tables {
            let k = table.kind.reaction();
            for ((rows, row), w) in reactions
                .iter()
                .zip(table.rows.iter_mut())
                .zip(table.writers.iter_mut())
            {
                // The reactions as their table prints them.
                self.printed.clear();
                self.printed
                    .extend(rows[k].iter().map(|&v| as_printed(v, p)));
                match &table.kind {
                    KneeKind::Loads { sides, patella, .. } => {
                        crate::reactions::knee_loads::knee_row(
                            &self.data,
                            sides,
                            *patella,
                            &self.printed,
                            row,
                        )
                    }
                    KneeKind::Contact { .. } => crate::reactions::knee_contact::row_into(
                        &self.data,
                        self.knees,
                        &self.printed,
                        row,
                    ),
                }
                w.write_row(t, row)?;
            }
            if let (Some(i), Some(stats)) = (table.stats, self.stats.as_mut()) {
                stats.push_rows(i, time, table.rows.iter().map(|r| r.as_slice()))?;
            }
        }
        Ok(())
    }

    /// The tables finished: per run, its tables' paths in the order added;
    /// then the statistics' paths per table in the order added (none for a
    /// single run).
    #[allow(clippy::type_complexity)]
    pub fn finish(mut self) -> Result<(Vec<Vec<PathBuf>>, Vec<Vec<PathBuf>>)> {
        self.open()?;
        let runs = self.tables.first().map_or(0, |t| t.paths.len());
        let mut per_run = vec![Vec::new(); runs];
        for t in self.tables {
            for w in t.writers {
                w.finish()?;
            }
            for (i, p) in t.paths.into_iter().enumerate() {
                per_run[i].push(p);
            }
        }
        let stats = match self.stats {
            Some(s) => s.finish()?,
            None => Vec::new(),
        };
        Ok((per_run, stats))
    }

    /// A pass stopped before its last frame has no knee tables: those
    /// begun are removed.
    pub fn abandon(self) {
        if let Some(s) = self.stats {
            s.abandon();
        }
        for t in self.tables {
            let begun = !t.writers.is_empty();
            drop(t.writers);
            if begun {
                for p in t.paths {
                    if crate::storage::results::writes_file(&p) {
                        let _ = std::fs::remove_file(p);
                    }
                }
            }
        }
    }
}
