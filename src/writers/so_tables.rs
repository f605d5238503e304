//! The tables of a static-optimization run, one row per frame in frame
//! order: activation, force (ForceReporter), diagnostics, generalized forces
//! by source, muscle power, joint reactions and, with contacts, the contact
//! forces, the forces per body and the contact forces as OpenSim external
//! loads (a `.mot` and its ExternalLoads document). Rows are written in
//! batches; a resumed run reopens each table after the rows it keeps.

use std::path::{Path, PathBuf};

use crate::error::Result;
use crate::frame::problem::{FrameResult, SoProblem};
use crate::reactions::{column_labels, ReactionSpec};
use crate::storage::StoWriter;
use crate::writers::names::{OutputKind, RunKey};
use crate::writers::tables::{
    diagnostics_row, DIAGNOSTICS_COLUMNS, DIAGNOSTICS_DESCRIPTION, FORCE_DESCRIPTION,
    JOINT_REACTION_DESCRIPTION,
};

/// A run's tables are written every this many frames, and at least every
/// [`TABLE_BATCH_AGE`] (one `write` per batch instead of per row; a killed
/// run loses at most the open batch, as its log loses the open chunk).
const TABLE_BATCH_ROWS: usize = 32;
const TABLE_BATCH_AGE: std::time::Duration = std::time::Duration::from_millis(200);

/// Where and how a run's tables are written.
pub struct TablesSpec<'a> {
    /// The setup file, named in each table's header.
    pub setup_file: &'a Path,
    pub dir: &'a Path,
    /// The run its files belong to (`writers::names`).
    pub run: &'a RunKey,
    /// The run's contact weight (in the contact table's description).
    pub w0: f64,
    /// Per joint-reaction table: its run and reactions.
    pub reactions: &'a [(RunKey, &'a [ReactionSpec])],
    pub precision: usize,
    /// Resuming: the rows every table keeps (None: new tables).
    pub keep: Option<usize>,
}

/// A run's open tables.
pub struct SoTables {
    act_w: StoWriter,
    force_w: StoWriter,
    diag_w: StoWriter,
    contact_w: Option<(StoWriter, StoWriter, StoWriter)>,
    src_w: StoWriter,
    power_w: StoWriter,
    jr_w: Vec<StoWriter>,
    /// The activation table's columns: the problem's controls.
    n_controls: usize,
    /// Every file, in the order the run's summary lists them.
    pub files: Vec<PathBuf>,
    /// The diagnostics table (named in warnings).
    pub diag_path: PathBuf,
}

impl SoTables {
    /// Creates the tables (or reopens them, resuming) and writes the
    /// contact forces' ExternalLoads document.
    pub fn open(problem: &SoProblem, spec: &TablesSpec) -> Result<SoTables> {
        let (dir, run, precision) = (spec.dir, spec.run, spec.precision);
        let act_path = dir.join(run.file(OutputKind::Activation));
        let force_path = dir.join(run.file(OutputKind::Force));
        let diag_path = dir.join(run.file(OutputKind::Diagnostics));
        let mut files = vec![act_path.clone(), force_path.clone(), diag_path.clone()];
        // Each table is created, or, when resuming, reopened after its kept
        // rows; rows are written in batches (TABLE_BATCH_ROWS).
        let open_table = |path: &std::path::Path,
                          name: &str,
                          desc: &str,
                          labels: &[String],
                          precision: usize|
         -> Result<StoWriter> {
            let mut w = match spec.keep {
                Some(keep) => StoWriter::resume(path, labels.len(), precision, keep),
                None => StoWriter::create_for_setup(
                    spec.setup_file,
                    path,
                    name,
                    desc,
                    labels,
                    precision,
                    false,
                ),
            }?;
            w.batch_rows(TABLE_BATCH_ROWS, TABLE_BATCH_AGE);
            Ok(w)
        };
        let act_w = open_table(
            &act_path,
            "Static Optimization",
            "This file contains static optimization results.\n",
            &problem.labels,
            precision,
        )?;
        let force_w = open_table(
            &force_path,
            "ModelForces",
            FORCE_DESCRIPTION,
            &problem.force_labels,
            precision,
        )?;
        let diag_labels: Vec<String> = DIAGNOSTICS_COLUMNS.iter().map(|s| s.to_string()).collect();
        let diag_w = open_table(
            &diag_path,
            "Static Optimization Diagnostics",
            DIAGNOSTICS_DESCRIPTION,
            &diag_labels,
            16,
        )?;
        let mut contact_w = None;
        if !problem.contacts.is_empty() {
            let cpath = dir.join(run.file(OutputKind::ContactForces));
            let bpath = dir.join(run.file(OutputKind::ContactBodyForces));
            let lpath = dir.join(run.file(OutputKind::ContactExternalLoads));
            let xpath = dir.join(run.file(OutputKind::ContactExternalLoadsXml));
            let desc = format!(
                "Contact forces estimated by statopt (Krueger & Wartzack 2017), contact weight w0 = {}, friction {:?}.\nPer contact: force on the point body (N, ground), application point p (m, ground), point-to-plane distance (m), weight w(d), slip speed (m/s), regime (0 static, 1 kinetic; between: kinetic share of a regime_blend), multipliers.\n",
                spec.w0, problem.options.friction
            );
            let cw = open_table(
                &cpath,
                "Contact Forces",
                &desc,
                &problem.contact_labels(),
                precision,
            )?;
            let bw = open_table(&bpath, "Contact Body Forces", "Contact forces summed per body: force (N, ground) and moment about the body origin (N m, ground).\n", &problem.contact_body_labels(), precision)?;
            let mut load_labels = Vec::new();
            for (_, _, id) in problem.contact_load_forces() {
                load_labels.extend(
                    [
                        "force_vx", "force_vy", "force_vz", "force_px", "force_py", "force_pz",
                    ]
                    .map(|s| format!("{id}{s}")),
                );
            }
            let lw = open_table(
                &lpath,
                "statopt contact forces",
                "",
                &load_labels,
                precision,
            )?;
            let datafile = lpath
                .file_name()
                .map(|f| f.to_string_lossy().to_string())
                .unwrap_or_default();
            crate::storage::results::write(
                &xpath,
                external_loads_xml(problem, &datafile).into_bytes(),
            )?;
            files.extend([cpath, bpath, lpath, xpath]);
            contact_w = Some((cw, bw, lw));
        }
        let src_path = dir.join(run.file(OutputKind::GeneralizedForcesBySource));
        let src_w = open_table(
            &src_path,
            "Generalized Forces By Source",
            "Per free coordinate (after coupling): the generalized force the motion requires (N or N m) and the parts muscles, other actuators and contacts supply; their sum equals the requirement on every solved frame.\n",
            &problem.by_source_labels(),
            precision,
        )?;
        let power_path = dir.join(run.file(OutputKind::MusclePower));
        let power_w = open_table(
            &power_path,
            "Muscle Power",
            "Mechanical power of each muscle (W): force x shortening speed of the musculotendon path; positive while shortening under tension.\n",
            &problem.muscle_labels(),
            precision,
        )?;
        files.extend([src_path, power_path]);
        let mut jr_w = Vec::new();
        for (jr, specs) in spec.reactions {
            let path = dir.join(jr.file(OutputKind::ReactionLoads));
            jr_w.push(open_table(
                &path,
                "Joint Reaction Loads",
                JOINT_REACTION_DESCRIPTION,
                &column_labels(specs),
                precision,
            )?);
            files.push(path);
        }
        Ok(SoTables {
            act_w,
            force_w,
            diag_w,
            contact_w,
            src_w,
            power_w,
            jr_w,
            n_controls: problem.controls.len(),
            files,
            diag_path,
        })
    }

    /// One frame's rows (in frame order), its joint reactions' rows beside.
    pub fn write(&mut self, r: &FrameResult, jr_rows: &[Vec<f64>]) -> Result<()> {
        for (w, row) in self.jr_w.iter_mut().zip(jr_rows) {
            w.write_row(r.time, row)?;
        }
        self.src_w.write_row(r.time, &r.by_source)?;
        self.power_w.write_row(r.time, &r.muscle_power)?;
        self.act_w
            .write_row(r.time, &r.solution.x[..self.n_controls])?;
        self.force_w.write_row(r.time, &r.force_row)?;
        self.diag_w.write_row(r.time, &diagnostics_row(r))?;
        if let Some((cw, bw, lw)) = self.contact_w.as_mut() {
            cw.write_row(r.time, &r.contacts.contact)?;
            bw.write_row(r.time, &r.contacts.bodies)?;
            lw.write_row(r.time, &r.contacts.loads)?;
        }
        Ok(())
    }

    /// Writes the rows still batched and each table's final row count;
    /// returns [`Self::files`].
    pub fn finish(self) -> Result<Vec<PathBuf>> {
        let mut tables = vec![
            self.act_w,
            self.force_w,
            self.diag_w,
            self.src_w,
            self.power_w,
        ];
        tables.extend(self.jr_w);
        if let Some((cw, bw, lw)) = self.contact_w {
            tables.extend([cw, bw, lw]);
        }
        for w in tables {
            w.finish()?;
        }
        Ok(self.files)
    }
}

/// OpenSim ExternalLoads document naming the exported contact-force data.
fn external_loads_xml(problem: &SoProblem, datafile: &str) -> String {
    use quick_xml::escape::escape;
    let mut forces = String::new();
    for (name, body, id) in problem.contact_load_forces() {
        forces.push_str(&format!(
            "\t\t\t<ExternalForce name=\"{}\">\n\t\t\t\t<appliesForce>true</appliesForce>\n\t\t\t\t<applied_to_body>{}</applied_to_body>\n\t\t\t\t<force_expressed_in_body>ground</force_expressed_in_body>\n\t\t\t\t<point_expressed_in_body>ground</point_expressed_in_body>\n\t\t\t\t<force_identifier>{}force_v</force_identifier>\n\t\t\t\t<point_identifier>{}force_p</point_identifier>\n\t\t\t\t<torque_identifier>Unassigned</torque_identifier>\n\t\t\t</ExternalForce>\n",
            escape(name.as_str()),
            escape(problem.model.bodies[body].name.as_str()),
            escape(id.as_str()),
            escape(id.as_str())
        ));
    }
    format!(
        "<?xml version=\"1.0\" encoding=\"UTF-8\" ?>\n<!-- Contact forces estimated by statopt, as OpenSim external loads: each contact's force on the point body at p and, for a plane body other than ground, the opposite force on the plane body at the projection p*. -->\n<OpenSimDocument Version=\"40000\">\n\t<ExternalLoads name=\"statopt_contact_forces\">\n\t\t<objects>\n{forces}\t\t</objects>\n\t\t<groups />\n\t\t<datafile>{}</datafile>\n\t</ExternalLoads>\n</OpenSimDocument>\n",
        escape(datafile)
    )
}
