//! The MCAP log of a static-optimization run: each frame's results
//! ([`FrameResult`] and its joint reactions) as the messages of the
//! channels `output::mcap_log` defines, and the log that writes them in
//! frame order. The tools' run drivers (`tools::static_optimization`) own
//! the threads that call it.

use crate::error::{Error, Location, Result};
use crate::frame::problem::{FrameResult, SoProblem, CONTACT_COLUMNS};
use crate::output::mcap_log;
use crate::reactions::ReactionSpec;

/// The run's MCAP log: one message per frame on each channel (see
/// `output::mcap_log` for the channels and message layout). Messages are
/// built and encoded by the frame workers ([`LogNames::encode`]); the log
/// only writes them in order.
pub struct FrameLog {
    log: mcap_log::McapLog,
}

/// Channel member names of a run's log (shared by the frame workers).
pub struct LogNames {
    coordinates: Vec<String>,
    labels: Vec<String>,
    contacts: Vec<String>,
    /// Reaction label roots of the first coupled JointReaction, if any.
    joints: Vec<String>,
    /// Writes each frame's messages straight to JSON bytes.
    encoder: mcap_log::MessageEncoder,
}

/// Encoded messages of one frame: (channel index, JSON bytes).
pub type FrameMessages = Vec<(usize, Vec<u8>)>;

impl LogNames {
    pub fn new(problem: &SoProblem, reactions: Option<&[ReactionSpec]>) -> LogNames {
        let coordinates: Vec<String> = problem
            .model
            .coordinates
            .iter()
            .map(|c| c.name.clone())
            .collect();
        let labels = problem.labels.clone();
        let contacts: Vec<String> = problem.contacts.iter().map(|c| c.name.clone()).collect();
        let joints: Vec<String> = reactions
            .map(|s| s.iter().map(|r| r.label_root.clone()).collect())
            .unwrap_or_default();
        let encoder = mcap_log::MessageEncoder::new(&mcap_log::StatoptChannels {
            coordinates: coordinates.clone(),
            activations: labels.clone(),
            forces: labels.clone(),
            contacts: contacts.clone(),
            joints: joints.clone(),
        });
        LogNames {
            coordinates,
            labels,
            contacts,
            joints,
            encoder,
        }
    }

    pub fn encode(
        &self,
        problem: &SoProblem,
        r: &FrameResult,
        jr_rows: &[Vec<f64>],
    ) -> Result<FrameMessages> {
        let t = r.time;
        let nv = problem.controls.len();
        let enc = &self.encoder;
        let mut out = Vec::with_capacity(6);
        let mut data = Vec::new();
        enc.kinematics(&mut data, t, &r.q, &r.u, &r.udot)?;
        out.push((mcap_log::KINEMATICS, std::mem::take(&mut data)));
        enc.activations(&mut data, t, &r.solution.x[..nv])?;
        out.push((mcap_log::ACTIVATIONS, std::mem::take(&mut data)));
        enc.muscle_forces(&mut data, t, &r.forces)?;
        out.push((mcap_log::MUSCLE_FORCES, std::mem::take(&mut data)));
        if !self.contacts.is_empty() {
            let samples: Vec<mcap_log::ContactSample> = r
                .contacts
                .contact
                .chunks(CONTACT_COLUMNS.len())
                .map(|c| mcap_log::ContactSample {
                    force: [c[0], c[1], c[2]],
                    point: [c[3], c[4], c[5]],
                    distance: c[6],
                    weight: c[7],
                    slip_speed: c[8],
                    // The table's regime column carries the kinetic share
                    // beta: 0 static, 1 kinetic, between: <regime_blend>.
                    regime: if c[9] >= 1.0 {
                        "kinetic".into()
                    } else if c[9] > 0.0 {
                        "blended".into()
                    } else {
                        "static".into()
                    },
                })
                .collect();
            enc.contacts(&mut data, t, &samples)?;
            out.push((mcap_log::CONTACTS, std::mem::take(&mut data)));
        }
        if let (Some(row), false) = (jr_rows.first(), self.joints.is_empty()) {
            let samples: Vec<mcap_log::JointReactionSample> = row
                .chunks(9)
                .map(|c| mcap_log::JointReactionSample {
                    force: [c[0], c[1], c[2]],
                    moment: [c[3], c[4], c[5]],
                })
                .collect();
            enc.joint_reactions(&mut data, t, &samples)?;
            out.push((mcap_log::JOINT_REACTIONS, std::mem::take(&mut data)));
        }
        let status = format!("{:?}", r.solution.status);
        enc.solver(
            &mut data,
            t,
            &status,
            r.solution.solver.name(),
            r.solution.iterations,
            r.solution.objective,
            r.solution.eq_residual,
            r.solution.solve_time,
        );
        out.push((mcap_log::SOLVER, data));
        Ok(out)
    }
}

impl FrameLog {
    /// Log again the messages a resumed run keeps (see [`resume_point`]).
    pub fn replay(&mut self, messages: &[(String, f64, Vec<u8>)]) -> Result<()> {
        for (topic, t, data) in messages {
            let idx = self.log.topic_index(topic).ok_or_else(|| {
                Error::input(
                    Location::file(self.log.path()),
                    format!("cannot resume: the log has a topic '{topic}' this run does not write"),
                )
            })?;
            self.log.log_serialized(idx, *t, data)?;
        }
        Ok(())
    }

    pub fn create(path: &std::path::Path, names: &LogNames) -> Result<FrameLog> {
        let channels = mcap_log::StatoptChannels {
            coordinates: names.coordinates.clone(),
            activations: names.labels.clone(),
            forces: names.labels.clone(),
            contacts: names.contacts.clone(),
            joints: names.joints.clone(),
        };
        Ok(FrameLog {
            log: mcap_log::McapLog::create(path, &channels.specs()?)?,
        })
    }

    /// Encode one frame's messages ([`LogNames::encode`]) and log them (in
    /// frame order).
    pub fn write_frame(
        &mut self,
        names: &LogNames,
        problem: &SoProblem,
        r: &FrameResult,
        jr_rows: &[Vec<f64>],
    ) -> Result<()> {
        let messages = names.encode(problem, r, jr_rows)?;
        self.write(r.time, &messages)
    }

    pub fn write(&mut self, t: f64, messages: &FrameMessages) -> Result<()> {
        for (idx, data) in messages {
            self.log.log_serialized(*idx, t, data)?;
        }
        Ok(())
    }

    pub fn finish(self) -> Result<()> {
        self.log.finish()
    }
}
