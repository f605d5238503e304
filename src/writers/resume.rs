//! Where a static-optimization run that an earlier one left unfinished
//! goes on: the frames every table of the run and its MCAP log hold
//! completely, read back from the files.

use crate::error::Result;
use crate::frame::problem::SoProblem;
use crate::reactions::ReactionSpec;
use crate::writers::names::{OutputKind, RunKey};

/// Where a resumed run goes on: the frames that every table of the run and
/// its MCAP log hold completely are kept.
pub struct Resume {
    /// Rows kept in every table.
    pub keep: usize,
    /// Time of the last kept frame.
    pub last_time: f64,
    /// The kept frames' log messages: topic, time, serialized message.
    pub messages: Vec<(String, f64, Vec<u8>)>,
}

/// The [`Resume`] of run `run` writing into `dir`, or None when it has
/// nothing to keep (no tables yet, or one of them or the log empty).
pub fn resume_point(
    dir: &std::path::Path,
    run: &RunKey,
    problem: &SoProblem,
    reactions: &[(RunKey, &[ReactionSpec])],
) -> Result<Option<Resume>> {
    // Every table of the run (`OutputKind::SO_TABLES`, the contact loads'
    // data beside), the contact tables only with contacts.
    let mut tables: Vec<std::path::PathBuf> = OutputKind::SO_TABLES
        .into_iter()
        .chain([OutputKind::ContactExternalLoads])
        .filter(|k| !k.needs_contacts() || !problem.contacts.is_empty())
        .map(|k| dir.join(run.file(k)))
        .collect();
    for (jr, _) in reactions {
        tables.push(dir.join(jr.file(OutputKind::ReactionLoads)));
    }
    let mut keep = usize::MAX;
    for t in &tables {
        keep = keep.min(crate::storage::complete_rows(t)?);
    }
    if keep == 0 {
        return Ok(None);
    }
    // The log: messages of whole frames, read as far as its chunks are
    // complete (a killed run's last chunk may be torn).
    let log_path = dir.join(run.file(OutputKind::Log));
    let bytes = match crate::storage::read_bytes(&log_path) {
        Ok(b) => b,
        Err(_) => return Ok(None),
    };
    let mut frames: Vec<Vec<(String, f64, Vec<u8>)>> = Vec::new();
    let mut last_stamp = None;
    if let Ok(stream) =
        mcap::MessageStream::new_with_options(&bytes, mcap::read::Options::IgnoreEndMagic.into())
    {
        for m in stream {
            let Ok(m) = m else { break };
            let t = serde_json::from_slice::<serde_json::Value>(&m.data)
                .ok()
                .and_then(|v| v.get("time").and_then(|t| t.as_f64()));
            let Some(t) = t else { break };
            if last_stamp != Some(m.log_time) {
                frames.push(Vec::new());
                last_stamp = Some(m.log_time);
            }
            frames.last_mut().expect("pushed above").push((
                m.channel.topic.clone(),
                t,
                m.data.into_owned(),
            ));
        }
    }
    // The last frame read may be incomplete: keep only frames followed by
    // another one.
    let whole = frames.len().saturating_sub(1);
    keep = keep.min(whole);
    if keep == 0 {
        return Ok(None);
    }
    frames.truncate(keep);
    let last_time = frames[keep - 1][0].1;
    Ok(Some(Resume {
        keep,
        last_time,
        messages: frames.into_iter().flatten().collect(),
    }))
}
