//! The BodyKinematics and PointKinematics analyses' tables: positions,
//! velocities and accelerations, one row per frame, with OpenSim 4.6's file
//! names (`names::body_kinematics_files`, `names::point_kinematics_files`),
//! table names, columns and `inDegrees` header.

use std::path::{Path, PathBuf};

use crate::error::Result;
use crate::storage::StoWriter;

/// How a run's kinematics tables are written.
pub struct TableSpec<'a> {
    /// The setup file (the tables' header names it).
    pub setup_file: &'a Path,
    pub dir: &'a Path,
    pub precision: usize,
    pub labels: &'a [String],
}

/// The position, velocity and acceleration tables of one analysis.
pub struct KinematicsTables {
    writers: Vec<(StoWriter, PathBuf)>,
}

const ACCELERATIONS: &str = "Accelerations are the motion's: those of the coordinates' \
accelerations u' = S_u' (static optimization's targets), not, as OpenSim 4.6's AnalyzeTool \
writes them, those of forward dynamics under the model's forces with its muscles' states at \
their defaults.";

impl KinematicsTables {
    /// BodyKinematics' tables `<setup>_<analysis>_pos_global.sto`,
    /// `_vel_global.sto`, `_acc_global.sto` (`_bodyLocal`).
    pub fn body(
        spec: &TableSpec,
        setup_name: &str,
        analysis: &str,
        model_name: &str,
        body_frame: bool,
        in_degrees: bool,
    ) -> Result<Self> {
        let files = super::names::body_kinematics_files(setup_name, analysis, body_frame);
        let expressed = if body_frame {
            "Velocities, accelerations, angular velocities and angular accelerations are expressed in the body-local frame (positions and the centre of mass in ground)."
        } else {
            "Velocities, accelerations, angular velocities and angular accelerations are expressed in the ground frame."
        };
        let description = format!(
            "This file contains the kinematics (positions and orientations,\nvelocities and angular velocities, or accelerations and angular accelerations)\nof the centers of mass of the body segments in model {model_name}.\n\nBody segment orientations are described using body-fixed X-Y-Z Euler angles.\n\n{expressed}\n\nUnits are S.I. units (seconds, meters, Newtons, ...); angles in {}.\n{ACCELERATIONS}\n",
            if in_degrees { "degrees" } else { "radians" }
        );
        Self::open(
            spec,
            &files,
            ["Positions", "Velocities", "Accelerations"],
            &description,
            in_degrees,
        )
    }

    /// PointKinematics' tables `<setup>_<analysis>_<point>_pos.sto`,
    /// `_vel.sto`, `_acc.sto`.
    pub fn point(
        spec: &TableSpec,
        setup_name: &str,
        analysis: &str,
        point_name: &str,
        what: &str,
    ) -> Result<Self> {
        let files = super::names::point_kinematics_files(setup_name, analysis, point_name);
        let description = format!(
            "This file contains the kinematics (position, velocity, or acceleration) of\n{what}.\n\nUnits are S.I. units (seconds, meters, Newtons,...)\n{ACCELERATIONS}\n"
        );
        Self::open(
            spec,
            &files,
            ["PointPosition", "PointVelocity", "PointAcceleration"],
            &description,
            false,
        )
    }

    fn open(
        spec: &TableSpec,
        files: &[String; 3],
        names: [&str; 3],
        description: &str,
        in_degrees: bool,
    ) -> Result<Self> {
        let mut writers = Vec::new();
        for (file, name) in files.iter().zip(names) {
            let path = spec.dir.join(file);
            writers.push((
                StoWriter::create_for_setup(
                    spec.setup_file,
                    &path,
                    name,
                    description,
                    spec.labels,
                    spec.precision,
                    in_degrees,
                )?,
                path,
            ));
        }
        Ok(KinematicsTables { writers })
    }

    /// One frame's rows: positions, velocities, accelerations.
    pub fn write(&mut self, t: f64, rows: [&[f64]; 3]) -> Result<()> {
        for ((w, _), row) in self.writers.iter_mut().zip(rows) {
            w.write_row(t, row)?;
        }
        Ok(())
    }

    /// Finish the tables; their paths.
    pub fn finish(self) -> Result<Vec<PathBuf>> {
        let mut out = Vec::new();
        for (w, p) in self.writers {
            w.finish()?;
            out.push(p);
        }
        Ok(out)
    }
}
