//! Streaming MCAP log of every solved frame.
//!
//! [MCAP](https://mcap.dev/spec) is a chunked, indexed container for
//! time-stamped messages; Foxglove opens it directly. The file is written
//! with the `mcap` crate; this module only decides the layout:
//!
//! - **Encoding.** Every channel has message encoding `json` and a schema
//!   with encoding `jsonschema` (a JSON Schema, draft 2020-12, as Foxglove
//!   expects for JSON channels). Keys keep their insertion order
//!   (`serde_json`'s `preserve_order`), so fields appear in model order.
//! - **Chunks.** Uncompressed by default ([`LogOptions::compression`]:
//!   zstd at level 1 cost a sixth of a gait2392 run's instructions, for a
//!   log three times smaller; `mcap compress` of the MCAP CLI compresses a
//!   finished log). A chunk is closed when it holds more than
//!   [`LogOptions::chunk_size`] uncompressed bytes (default 256 KiB, a few
//!   hundred frames for a small model) or when [`LogOptions::max_chunk_age`]
//!   (default 2 s of wall-clock time) has passed since the last chunk was
//!   closed, whichever comes first. Chunks are assembled in memory and
//!   written to the file in one piece when closed (one `write`), so the
//!   file on disk only ever ends in complete chunks, apart from a write
//!   torn by the kill itself. The small records around them (each chunk's
//!   message indexes, the summary, the footer) are gathered in a buffer
//!   ([`FileSink`], no larger than a chunk; a compressed log's, whose
//!   chunks may be smaller, is not buffered) and written ahead of the next
//!   chunk, at [`McapLog::flush`] and at the end: gait2392's log took 169 `write`
//!   calls, most of a few bytes, when they went straight to the file.
//! - **Time.** MCAP stamps are unsigned nanoseconds, but OpenSim frames can
//!   have negative times (padded motions). The rule is
//!   `log_time = publish_time = round((time − t0) · 1e9)` ns, with `t0` the
//!   time of the first message logged (or the value given to
//!   [`McapLog::set_time_origin`] before it). A message earlier than `t0`
//!   is an error. The original time is always in the message as its
//!   `time` field (in seconds, exactly as given), and `t0` is recorded in a
//!   metadata record named [`TIME_ORIGIN_METADATA`] (keys `t0` and `rule`).
//!
//! # What a killed run leaves
//!
//! The header, the schemas and the channels are written (as a first chunk)
//! by [`McapLog::create`]. After that, every closed chunk is on disk. A run
//! killed hard (SIGKILL, power loss for data not yet synced, `abort`)
//! leaves a file without summary, footer or end magic whose complete chunks
//! hold every message up to the last chunk boundary; the messages of the
//! open chunk (at most `chunk_size` bytes or `max_chunk_age` seconds of
//! frames) are lost. Such a file is read by a linear (non-summary) reader
//! that does not require the end magic and stops at the first incomplete
//! record, e.g. `mcap::MessageStream::new_with_options(buf,
//! mcap::read::Options::IgnoreEndMagic.into())` in Rust,
//! `mcap.stream_reader.StreamReader` in Python (see
//! `scripts/check_mcap.py --allow-truncated`), or `mcap recover` with the
//! MCAP CLI, which rewrites it as a complete file. A run that merely fails
//! with an error (or panics and unwinds) drops the [`McapLog`], and the
//! `mcap` writer's `Drop` writes the summary and footer: the file is then
//! complete, only [`McapLog::finish`] reports errors of that last step.
//!
//! # Message layout (statopt channels)
//!
//! Foxglove's plot panel addresses values by message path
//! (`/activations.TRIlong`); an array element needs an index
//! (`/kinematics.q[3]`) that says nothing about what it is. So every value
//! is a *named* scalar field: `/activations` is
//! `{"time": 0.01, "TRIlong": 0.12, "TRIlat": 0.08, …}`, `/kinematics` is
//! `{"time", "q": {coord: value}, "qdot": {…}, "qddot": {…}}`, 3-vectors are
//! `{"x","y","z"}` objects. Every field can then be plotted without set-up.
//! A non-finite value (JSON has no NaN or ∞) is left out of its message, so
//! it shows as a gap in a plot; schemas therefore require only `time` (and,
//! for `/solver`, `status`). Field names are the model's names; names must
//! be unique, non-empty and not `time`.
//!
//! The topics, in channel order (the `idx` for [`McapLog::log`]):
//! [`KINEMATICS`] `/kinematics`, [`ACTIVATIONS`] `/activations`,
//! [`MUSCLE_FORCES`] `/muscle_forces`, [`CONTACTS`] `/contacts`,
//! [`JOINT_REACTIONS`] `/joint_reactions`, [`SOLVER`] `/solver`.
//! Units are the model's internal units (rad or m, N or N·m, s), never
//! degrees.

use std::collections::{BTreeMap, HashSet};
use std::fs::File;
use std::io::{Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use mcap::records::{MessageHeader, Metadata};
use serde_json::{json, Map, Value};

use crate::error::{Error, Location, Result};

#[cfg(test)]
mod mcaplog_tests;

/// Name of the metadata record that stores the time origin `t0`.
pub const TIME_ORIGIN_METADATA: &str = "statopt.time_origin";
/// JSON Schema dialect of every schema written here.
pub const JSON_SCHEMA_DIALECT: &str = "https://json-schema.org/draft/2020-12/schema";

/// zstd level of the chunks when [`LogOptions::compression`] asks for zstd:
/// 1, zstd's fastest positive level. On statopt's JSON messages it
/// compresses about twice as fast as the default level 3, and as well
/// (gait2392: 422 kB against 450 kB).
pub const ZSTD_LEVEL: u32 = 1;

/// One channel of the log: a topic and the JSON Schema of its messages.
#[derive(Debug, Clone, PartialEq)]
pub struct ChannelSpec {
    pub topic: String,
    pub schema_name: String,
    /// JSON Schema (draft 2020-12) of the channel's messages.
    pub schema: Value,
}

/// Chunking of the log (see the module documentation).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LogOptions {
    /// Close a chunk once it holds more than this many uncompressed bytes.
    pub chunk_size: u64,
    /// Also close the open chunk at the first message logged this long
    /// (wall-clock) after the last chunk was closed; `None` for size only.
    pub max_chunk_age: Option<Duration>,
    /// Compression of the chunks: none (the default) or zstd at
    /// [`ZSTD_LEVEL`]. Measured on gait2392's 151 frames (callgrind, whole
    /// process): zstd took 36 M of 224 M instructions and left 0.40 MB of
    /// the log's 1.24 MB; LZ4, the other compression MCAP readers know, is
    /// not among this crate's dependencies.
    pub compression: ChunkCompression,
}

/// How a log's chunks are compressed (see [`LogOptions::compression`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ChunkCompression {
    None,
    /// zstd at [`ZSTD_LEVEL`].
    Zstd,
}

impl Default for LogOptions {
    fn default() -> Self {
        LogOptions {
            chunk_size: 256 * 1024,
            max_chunk_age: Some(Duration::from_secs(2)),
            compression: ChunkCompression::None,
        }
    }
}

/// An MCAP file being written.
pub struct McapLog {
    path: PathBuf,
    writer: mcap::Writer<FileSink>,
    /// MCAP channel id of each [`ChannelSpec`], by index.
    channel_ids: Vec<u16>,
    topics: Vec<String>,
    sequences: Vec<u32>,
    t0: Option<f64>,
    max_chunk_age: Option<Duration>,
    last_chunk_closed: Instant,
}

impl McapLog {
    /// Creates the file (replacing an existing one) and registers one
    /// channel per spec (message encoding `json`, schema encoding
    /// `jsonschema`), with the default [`LogOptions`].
    pub fn create(path: &Path, channels: &[ChannelSpec]) -> Result<McapLog> {
        McapLog::create_with_options(path, channels, LogOptions::default())
    }

    /// [`McapLog::create`] with explicit chunking options.
    pub fn create_with_options(
        path: &Path,
        channels: &[ChannelSpec],
        options: LogOptions,
    ) -> Result<McapLog> {
        let mut seen = HashSet::new();
        for spec in channels {
            if spec.topic.is_empty() {
                return Err(Error::input(
                    Location::file(path),
                    "MCAP channel with an empty topic",
                ));
            }
            if !seen.insert(spec.topic.as_str()) {
                return Err(Error::input(
                    Location::file(path),
                    format!("MCAP topic '{}' is given twice", spec.topic),
                ));
            }
            if !spec.schema.is_object() {
                return Err(Error::input(
                    Location::file(path),
                    format!("schema of MCAP topic '{}' is not a JSON object", spec.topic),
                ));
            }
        }
        if options.chunk_size == 0 {
            return Err(Error::input(
                Location::file(path),
                "MCAP chunk size must be positive",
            ));
        }

        let file = crate::storage::create_output(path).map_err(|e| Error::io(path, e))?;
        let write_options = mcap::WriteOptions::new()
            .compression(match options.compression {
                ChunkCompression::None => None,
                ChunkCompression::Zstd => Some(mcap::Compression::Zstd),
            })
            .compression_level(ZSTD_LEVEL)
            .compression_threads(0)
            .chunk_size(Some(options.chunk_size))
            // Assemble each chunk in memory and write it whole: the file
            // then never holds a chunk with placeholder lengths.
            .disable_seeking(true)
            .library(format!(
                "statopt {} ({})",
                env!("CARGO_PKG_VERSION"),
                mcap::LIBRARY_IDENTIFIER
            ));
        // A closed chunk holds more than `chunk_size` bytes: with a buffer
        // no larger, it goes to the file at once. A compressed chunk may be
        // smaller, so a compressed log is not buffered.
        let buffer = match options.compression {
            ChunkCompression::None => options.chunk_size.min(FileSink::BUFFER as u64) as usize,
            ChunkCompression::Zstd => 0,
        };
        let writer = write_options
            .create(FileSink::new(file, buffer))
            .map_err(|e| mcap_error(path, None, e))?;
        let mut log = McapLog {
            path: path.to_path_buf(),
            writer,
            channel_ids: Vec::with_capacity(channels.len()),
            topics: Vec::with_capacity(channels.len()),
            sequences: vec![0; channels.len()],
            t0: None,
            max_chunk_age: options.max_chunk_age,
            last_chunk_closed: Instant::now(),
        };
        for spec in channels {
            let schema = serde_json::to_vec(&spec.schema).map_err(|e| {
                Error::internal(format!("schema of MCAP topic '{}': {e}", spec.topic))
            })?;
            let schema_id = log
                .writer
                .add_schema(&spec.schema_name, "jsonschema", &schema)
                .map_err(|e| mcap_error(path, Some(&spec.topic), e))?;
            let channel_id = log
                .writer
                .add_channel(schema_id, &spec.topic, "json", &BTreeMap::new())
                .map_err(|e| mcap_error(path, Some(&spec.topic), e))?;
            log.channel_ids.push(channel_id);
            log.topics.push(spec.topic.clone());
        }
        // Put the schemas and channels on disk now, so that even a run
        // killed before its first full chunk leaves a file that names them.
        log.flush()?;
        Ok(log)
    }

    /// Path of the file being written.
    /// Index of the channel of `topic`.
    pub fn topic_index(&self, topic: &str) -> Option<usize> {
        self.topics.iter().position(|t| t == topic)
    }

    pub fn path(&self) -> &Path {
        &self.path
    }

    /// The time origin `t0` (seconds), once set.
    pub fn time_origin(&self) -> Option<f64> {
        self.t0
    }

    /// Sets the time origin `t0` explicitly (before the first message).
    pub fn set_time_origin(&mut self, t0: f64) -> Result<()> {
        if let Some(old) = self.t0 {
            return Err(Error::internal(format!(
                "{}: MCAP time origin already set to {old}",
                self.path.display()
            )));
        }
        if !t0.is_finite() {
            return Err(Error::input(
                Location::file(&self.path),
                format!("MCAP time origin {t0} is not finite"),
            ));
        }
        self.t0 = Some(t0);
        let mut metadata = BTreeMap::new();
        // `{:?}` of an f64 is the shortest string that parses back exactly.
        metadata.insert("t0".to_string(), format!("{t0:?}"));
        metadata.insert(
            "rule".to_string(),
            "log_time_ns = publish_time_ns = round((time - t0) * 1e9)".to_string(),
        );
        self.writer
            .write_metadata(&Metadata {
                name: TIME_ORIGIN_METADATA.to_string(),
                metadata,
            })
            .map_err(|e| mcap_error(&self.path, None, e))?;
        self.last_chunk_closed = Instant::now();
        Ok(())
    }

    /// Logs one message (a JSON object) on channel `idx` at time `t`
    /// seconds. The message gets a `time` field equal to `t` (if it already
    /// has one, it must equal `t`). The stamp is
    /// `round((t − t0) · 1e9)` ns (module documentation).
    pub fn log(&mut self, idx: usize, t: f64, msg: &Value) -> Result<()> {
        let topic = self.topics.get(idx).cloned().unwrap_or_default();
        let data = serialize_message(t, msg)
            .map_err(|e| e.context(format!("{}: MCAP topic '{topic}'", self.path.display())))?;
        self.log_serialized(idx, t, &data)
    }

    /// Log a message already serialized by [`serialize_message`] (so that
    /// callers can build and encode messages in parallel and only write here).
    pub fn log_serialized(&mut self, idx: usize, t: f64, data: &[u8]) -> Result<()> {
        let Some(&channel_id) = self.channel_ids.get(idx) else {
            return Err(Error::internal(format!(
                "{}: MCAP channel index {idx} out of range ({} channels)",
                self.path.display(),
                self.channel_ids.len()
            )));
        };
        if !t.is_finite() {
            return Err(Error::input(
                Location::file(&self.path).with_element(self.topics[idx].clone()),
                format!("message time {t} is not finite"),
            ));
        }
        if self.t0.is_none() {
            self.set_time_origin(t)?;
        }
        let stamp = time_to_ns(t, self.t0.unwrap_or(t)).ok_or_else(|| {
            Error::input(
                Location::file(&self.path).with_element(self.topics[idx].clone()),
                format!(
                    "message time {t} s is before the log's time origin {} s (or too far after it)",
                    self.t0.unwrap_or(t)
                ),
            )
        })?;

        if let Some(age) = self.max_chunk_age {
            if self.last_chunk_closed.elapsed() >= age {
                self.flush()?;
            }
        }
        let sequence = self.sequences[idx];
        self.sequences[idx] = sequence.wrapping_add(1);
        let header = MessageHeader {
            channel_id,
            sequence,
            log_time: stamp,
            publish_time: stamp,
        };
        self.writer
            .write_to_known_channel(&header, data)
            .map_err(|e| mcap_error(&self.path, Some(&self.topics[idx]), e))
    }

    /// Closes the open chunk (if any) and writes it to the file, so that
    /// every message logged so far survives a kill.
    pub fn flush(&mut self) -> Result<()> {
        self.writer
            .flush()
            .map_err(|e| mcap_error(&self.path, None, e))?;
        self.last_chunk_closed = Instant::now();
        Ok(())
    }

    /// Closes the last chunk, writes the summary (schemas, channels,
    /// statistics, chunk and metadata indexes), the footer and the end
    /// magic, and closes the file (as `StoWriter::finish`: the bytes are
    /// in the file, on the disk itself once the system writes them back or
    /// `--sync` asks, `tools::sync_files`).
    pub fn finish(mut self) -> Result<()> {
        self.writer
            .finish()
            .map_err(|e| mcap_error(&self.path, None, e))?;
        let path = self.path;
        let mut file = self.writer.into_inner();
        file.flush().map_err(|e| Error::io(&path, e))
    }
}

/// The log's file behind a write buffer that knows its position: the
/// `mcap` writer asks for the position before every index record, which
/// through a plain `BufWriter` would flush (and `lseek`) each time. Writes
/// at least as large as the buffer (a closed chunk: the buffer is no
/// larger than the chunk size) go to the file in one `write`, after what
/// the buffer holds, so a killed run leaves every closed chunk on disk.
struct FileSink {
    file: std::io::BufWriter<File>,
    pos: u64,
}

impl FileSink {
    /// Bytes gathered before a `write`, at most: more than a chunk's
    /// message indexes and the summary of a log with a few dozen chunks.
    const BUFFER: usize = 64 * 1024;

    /// `buffer` 0: every write goes straight to the file.
    fn new(file: File, buffer: usize) -> Self {
        FileSink {
            file: std::io::BufWriter::with_capacity(buffer, file),
            pos: 0,
        }
    }
}

impl Write for FileSink {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        let n = self.file.write(buf)?;
        self.pos += n as u64;
        Ok(n)
    }

    fn write_all(&mut self, buf: &[u8]) -> std::io::Result<()> {
        self.file.write_all(buf)?;
        self.pos += buf.len() as u64;
        Ok(())
    }

    fn flush(&mut self) -> std::io::Result<()> {
        self.file.flush()
    }
}

impl Seek for FileSink {
    /// The position is counted, so asking for it costs nothing; a real
    /// seek (the `mcap` writer seeks only when it may, which this log's
    /// options forbid) writes the buffer first.
    fn seek(&mut self, pos: SeekFrom) -> std::io::Result<u64> {
        if pos == SeekFrom::Current(0) {
            return Ok(self.pos);
        }
        self.pos = self.file.seek(pos)?;
        Ok(self.pos)
    }

    fn stream_position(&mut self) -> std::io::Result<u64> {
        Ok(self.pos)
    }
}

/// `round((t − t0) · 1e9)` as u64 nanoseconds; `None` when negative (by
/// more than half a nanosecond) or beyond u64.
pub fn time_to_ns(t: f64, t0: f64) -> Option<u64> {
    let ns = ((t - t0) * 1e9).round();
    // 2^64 is exactly representable; every f64 below it fits in u64.
    if (0.0..18_446_744_073_709_551_616.0).contains(&ns) {
        Some(ns as u64)
    } else {
        None
    }
}

fn mcap_error(path: &Path, topic: Option<&str>, err: mcap::McapError) -> Error {
    let mut loc = Location::file(path);
    if let Some(topic) = topic {
        loc = loc.with_element(format!("topic {topic}"));
    }
    Error::input(loc, format!("cannot write MCAP file: {err}"))
}

// ---------------------------------------------------------------------------
// Schema helpers
// ---------------------------------------------------------------------------

fn number() -> Value {
    json!({"type": "number"})
}

fn vec3_schema(description: &str) -> Value {
    json!({
        "type": "object",
        "description": description,
        "properties": {"x": number(), "y": number(), "z": number()},
        "additionalProperties": false
    })
}

/// Encode a message for [`McapLog::log_serialized`]: a JSON object with
/// `time` first (added when absent; an existing `time` must equal `t`).
pub fn serialize_message(t: f64, msg: &Value) -> Result<Vec<u8>> {
    let Some(obj) = msg.as_object() else {
        return Err(Error::internal("an MCAP message must be a JSON object"));
    };
    match obj.get("time") {
        Some(v) if v.as_f64() == Some(t) => serde_json::to_vec(msg),
        Some(v) => {
            return Err(Error::internal(format!(
                "message has time {v} but is logged at {t}"
            )))
        }
        None => {
            let mut with_time = Map::with_capacity(obj.len() + 1);
            with_time.insert("time".to_string(), json!(t));
            with_time.extend(obj.iter().map(|(k, v)| (k.clone(), v.clone())));
            serde_json::to_vec(&Value::Object(with_time))
        }
    }
    .map_err(|e| Error::internal(format!("encoding an MCAP message: {e}")))
}

/// JSON Schema of an object with a number field `time`, the given number
/// fields and the given fixed-length number arrays (all required).
/// Generic helper; the statopt channels below use named scalars instead of
/// arrays (module documentation).
pub fn object_schema(title: &str, number_fields: &[&str], array_fields: &[(&str, usize)]) -> Value {
    let mut properties = Map::new();
    let mut required = vec![Value::from("time")];
    properties.insert("time".to_string(), number());
    for &name in number_fields {
        if name != "time" {
            properties.insert(name.to_string(), number());
            required.push(Value::from(name));
        }
    }
    for &(name, len) in array_fields {
        properties.insert(
            name.to_string(),
            json!({
                "type": "array",
                "items": number(),
                "minItems": len,
                "maxItems": len
            }),
        );
        required.push(Value::from(name));
    }
    json!({
        "$schema": JSON_SCHEMA_DIALECT,
        "title": title,
        "type": "object",
        "properties": properties,
        "required": required
    })
}

/// Checks that `names` can be field names: non-empty, unique, not `time`.
fn check_names(what: &str, names: &[&str]) -> Result<()> {
    let mut seen = HashSet::new();
    for &name in names {
        if name.is_empty() {
            return Err(Error::msg(format!("{what}: empty name")));
        }
        if name == "time" {
            return Err(Error::msg(format!(
                "{what}: 'time' cannot be a name (it is the time field)"
            )));
        }
        if !seen.insert(name) {
            return Err(Error::msg(format!("{what}: name '{name}' appears twice")));
        }
    }
    Ok(())
}

/// Schema of `{"time": number, name_1: <field>, …}`.
fn named_schema(title: &str, description: &str, top: &[(&str, Value)], required: &[&str]) -> Value {
    let mut properties = Map::new();
    properties.insert(
        "time".to_string(),
        json!({"type": "number", "description": "time (s)"}),
    );
    for (name, schema) in top {
        properties.insert(name.to_string(), schema.clone());
    }
    let mut req = vec![Value::from("time")];
    req.extend(required.iter().map(|&r| Value::from(r)));
    json!({
        "$schema": JSON_SCHEMA_DIALECT,
        "title": title,
        "description": description,
        "type": "object",
        "properties": properties,
        "required": req,
        "additionalProperties": false
    })
}

fn named_numbers_schema(description: &str, names: &[&str]) -> Value {
    let mut properties = Map::new();
    for &name in names {
        properties.insert(name.to_string(), number());
    }
    json!({
        "type": "object",
        "description": description,
        "properties": properties,
        "additionalProperties": false
    })
}

// ---------------------------------------------------------------------------
// statopt channels
// ---------------------------------------------------------------------------

/// Channel index of `/kinematics` in [`StatoptChannels::specs`].
pub const KINEMATICS: usize = 0;
/// Channel index of `/activations`.
pub const ACTIVATIONS: usize = 1;
/// Channel index of `/muscle_forces`.
pub const MUSCLE_FORCES: usize = 2;
/// Channel index of `/contacts`.
pub const CONTACTS: usize = 3;
/// Channel index of `/joint_reactions`.
pub const JOINT_REACTIONS: usize = 4;
/// Channel index of `/solver`.
pub const SOLVER: usize = 5;

/// `/kinematics`: `{"time", "q": {coord: value}, "qdot": {…}, "qddot": {…}}`.
pub fn kinematics_channel(coordinates: &[&str]) -> Result<ChannelSpec> {
    check_names("/kinematics coordinates", coordinates)?;
    let schema = named_schema(
        "statopt.Kinematics",
        "Generalized coordinates, speeds and accelerations of every coordinate \
         (model units: rad or m, per s, per s^2), keyed by coordinate name.",
        &[
            ("q", named_numbers_schema("coordinate values", coordinates)),
            (
                "qdot",
                named_numbers_schema("coordinate speeds", coordinates),
            ),
            (
                "qddot",
                named_numbers_schema("coordinate accelerations", coordinates),
            ),
        ],
        &[],
    );
    Ok(ChannelSpec {
        topic: "/kinematics".to_string(),
        schema_name: "statopt.Kinematics".to_string(),
        schema,
    })
}

fn named_scalar_channel(
    topic: &str,
    schema_name: &str,
    description: &str,
    names: &[&str],
) -> Result<ChannelSpec> {
    check_names(topic, names)?;
    let fields: Vec<(&str, Value)> = names.iter().map(|&n| (n, number())).collect();
    Ok(ChannelSpec {
        topic: topic.to_string(),
        schema_name: schema_name.to_string(),
        schema: named_schema(schema_name, description, &fields, &[]),
    })
}

/// `/activations`: `{"time", actuator: activation or control, …}`.
pub fn activations_channel(actuators: &[&str]) -> Result<ChannelSpec> {
    named_scalar_channel(
        "/activations",
        "statopt.Activations",
        "Activation of each muscle (0..1) and control of each other actuator, keyed by actuator name.",
        actuators,
    )
}

/// `/muscle_forces`: `{"time", actuator: force, …}`.
pub fn muscle_forces_channel(actuators: &[&str]) -> Result<ChannelSpec> {
    named_scalar_channel(
        "/muscle_forces",
        "statopt.MuscleForces",
        "Force (N) or torque (N m) of each muscle and actuator, keyed by actuator name.",
        actuators,
    )
}

/// `/contacts`: `{"time", contact: {"force": {x,y,z}, "point": {x,y,z},
/// "distance", "weight", "slip_speed", "regime"}, …}`.
pub fn contacts_channel(contacts: &[&str]) -> Result<ChannelSpec> {
    check_names("/contacts", contacts)?;
    let entry = json!({
        "type": "object",
        "properties": {
            "force": vec3_schema("contact force on the body (N), in ground"),
            "point": vec3_schema("contact point (m), in ground"),
            "distance": {"type": "number", "description": "signed distance to the contact surface (m)"},
            "weight": {"type": "number", "description": "objective weight of the contact forces"},
            "slip_speed": {"type": "number", "description": "tangential speed of the contact point (m/s)"},
            "regime": {"type": "string", "description": "contact regime: static, kinetic, or blended (0 < beta < 1 under regime_blend)"}
        },
        "additionalProperties": false
    });
    let fields: Vec<(&str, Value)> = contacts.iter().map(|&n| (n, entry.clone())).collect();
    Ok(ChannelSpec {
        topic: "/contacts".to_string(),
        schema_name: "statopt.Contacts".to_string(),
        schema: named_schema(
            "statopt.Contacts",
            "State and force of each contact, keyed by contact name.",
            &fields,
            &[],
        ),
    })
}

/// `/joint_reactions`: `{"time", joint: {"force": {x,y,z}, "moment": {x,y,z}}, …}`.
pub fn joint_reactions_channel(joints: &[&str]) -> Result<ChannelSpec> {
    check_names("/joint_reactions", joints)?;
    let entry = json!({
        "type": "object",
        "properties": {
            "force": vec3_schema("reaction force (N) on the child body, in ground"),
            "moment": vec3_schema("reaction moment (N m) on the child body about the joint centre, in ground")
        },
        "additionalProperties": false
    });
    let fields: Vec<(&str, Value)> = joints.iter().map(|&n| (n, entry.clone())).collect();
    Ok(ChannelSpec {
        topic: "/joint_reactions".to_string(),
        schema_name: "statopt.JointReactions".to_string(),
        schema: named_schema(
            "statopt.JointReactions",
            "Joint reaction loads (OpenSim JointReaction defaults: on the child, expressed in ground), keyed by joint name.",
            &fields,
            &[],
        ),
    })
}

/// `/solver`: `{"time", "status", "solver", "iterations", "objective", "residual", "solve_time_ms"}`.
pub fn solver_channel() -> ChannelSpec {
    let fields = [
        (
            "status",
            json!({"type": "string", "description": "solver status"}),
        ),
        (
            "solver",
            json!({"type": "string", "enum": ["newton", "clarabel"], "description": "the solver that answered: the dual Newton method or Clarabel"}),
        ),
        (
            "iterations",
            json!({"type": "integer", "minimum": 0, "description": "Newton linear solves, or Clarabel's interior-point iterations (plus the solves of a failed Newton attempt)"}),
        ),
        (
            "objective",
            json!({"type": "number", "description": "objective value"}),
        ),
        (
            "residual",
            json!({"type": "number", "description": "equality-constraint residual"}),
        ),
        (
            "solve_time_ms",
            json!({"type": "number", "description": "wall-clock solve time (ms)"}),
        ),
    ];
    ChannelSpec {
        topic: "/solver".to_string(),
        schema_name: "statopt.Solver".to_string(),
        schema: named_schema(
            "statopt.Solver",
            "Outcome of the frame's optimization.",
            &fields,
            &["status"],
        ),
    }
}

/// The names that fix the statopt channel set.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct StatoptChannels {
    pub coordinates: Vec<String>,
    /// Actuators of `/activations` (muscles and other actuators).
    pub activations: Vec<String>,
    /// Actuators of `/muscle_forces`.
    pub forces: Vec<String>,
    pub contacts: Vec<String>,
    pub joints: Vec<String>,
}

impl StatoptChannels {
    /// The six channels, in the order of [`KINEMATICS`] … [`SOLVER`].
    pub fn specs(&self) -> Result<Vec<ChannelSpec>> {
        fn s(v: &[String]) -> Vec<&str> {
            v.iter().map(String::as_str).collect()
        }
        Ok(vec![
            kinematics_channel(&s(&self.coordinates))?,
            activations_channel(&s(&self.activations))?,
            muscle_forces_channel(&s(&self.forces))?,
            contacts_channel(&s(&self.contacts))?,
            joint_reactions_channel(&s(&self.joints))?,
            solver_channel(),
        ])
    }
}

// ---------------------------------------------------------------------------
// statopt messages (the `time` field is added by `McapLog::log`)
// ---------------------------------------------------------------------------

/// Inserts `value` under `name` if it is finite (JSON has no NaN/∞).
fn put(map: &mut Map<String, Value>, name: &str, value: f64) {
    if value.is_finite() {
        map.insert(name.to_string(), json!(value));
    }
}

fn named_numbers(what: &str, names: &[&str], values: &[f64]) -> Result<Map<String, Value>> {
    if names.len() != values.len() {
        return Err(Error::internal(format!(
            "{what}: {} names but {} values",
            names.len(),
            values.len()
        )));
    }
    let mut map = Map::with_capacity(names.len());
    for (&name, &v) in names.iter().zip(values) {
        put(&mut map, name, v);
    }
    Ok(map)
}

fn vec3(v: &[f64; 3]) -> Value {
    let mut map = Map::with_capacity(3);
    put(&mut map, "x", v[0]);
    put(&mut map, "y", v[1]);
    put(&mut map, "z", v[2]);
    Value::Object(map)
}

/// Message of [`kinematics_channel`].
pub fn kinematics_message(
    coordinates: &[&str],
    q: &[f64],
    qdot: &[f64],
    qddot: &[f64],
) -> Result<Value> {
    let mut msg = Map::with_capacity(3);
    msg.insert(
        "q".into(),
        Value::Object(named_numbers("/kinematics q", coordinates, q)?),
    );
    msg.insert(
        "qdot".into(),
        Value::Object(named_numbers("/kinematics qdot", coordinates, qdot)?),
    );
    msg.insert(
        "qddot".into(),
        Value::Object(named_numbers("/kinematics qddot", coordinates, qddot)?),
    );
    Ok(Value::Object(msg))
}

/// Message of [`activations_channel`] or [`muscle_forces_channel`]:
/// `{name: value, …}`.
pub fn named_values_message(names: &[&str], values: &[f64]) -> Result<Value> {
    Ok(Value::Object(named_numbers("named values", names, values)?))
}

/// One contact's entry in `/contacts`.
#[derive(Debug, Clone, PartialEq)]
pub struct ContactSample {
    pub force: [f64; 3],
    pub point: [f64; 3],
    pub distance: f64,
    pub weight: f64,
    pub slip_speed: f64,
    pub regime: String,
}

/// Message of [`contacts_channel`].
pub fn contacts_message(contacts: &[&str], samples: &[ContactSample]) -> Result<Value> {
    if contacts.len() != samples.len() {
        return Err(Error::internal(format!(
            "/contacts: {} names but {} samples",
            contacts.len(),
            samples.len()
        )));
    }
    let mut msg = Map::with_capacity(contacts.len());
    for (&name, c) in contacts.iter().zip(samples) {
        let mut e = Map::with_capacity(6);
        e.insert("force".into(), vec3(&c.force));
        e.insert("point".into(), vec3(&c.point));
        put(&mut e, "distance", c.distance);
        put(&mut e, "weight", c.weight);
        put(&mut e, "slip_speed", c.slip_speed);
        e.insert("regime".into(), Value::from(c.regime.as_str()));
        msg.insert(name.to_string(), Value::Object(e));
    }
    Ok(Value::Object(msg))
}

/// One joint's entry in `/joint_reactions`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JointReactionSample {
    pub force: [f64; 3],
    pub moment: [f64; 3],
}

/// Message of [`joint_reactions_channel`].
pub fn joint_reactions_message(joints: &[&str], samples: &[JointReactionSample]) -> Result<Value> {
    if joints.len() != samples.len() {
        return Err(Error::internal(format!(
            "/joint_reactions: {} names but {} samples",
            joints.len(),
            samples.len()
        )));
    }
    let mut msg = Map::with_capacity(joints.len());
    for (&name, r) in joints.iter().zip(samples) {
        msg.insert(
            name.to_string(),
            json!({"force": vec3(&r.force), "moment": vec3(&r.moment)}),
        );
    }
    Ok(Value::Object(msg))
}

/// Message of [`solver_channel`].
pub fn solver_message(
    status: &str,
    solver: &str,
    iterations: u32,
    objective: f64,
    residual: f64,
    solve_time: Duration,
) -> Value {
    let mut msg = Map::with_capacity(6);
    msg.insert("status".into(), Value::from(status));
    msg.insert("solver".into(), Value::from(solver));
    msg.insert("iterations".into(), Value::from(iterations));
    put(&mut msg, "objective", objective);
    put(&mut msg, "residual", residual);
    put(&mut msg, "solve_time_ms", solve_time.as_secs_f64() * 1e3);
    Value::Object(msg)
}

// ---------------------------------------------------------------------------
// statopt messages written straight to bytes
// ---------------------------------------------------------------------------

/// Writes the statopt messages as JSON bytes straight from the numbers:
/// byte for byte what [`serialize_message`] makes of the values built by
/// [`kinematics_message`], [`named_values_message`], [`contacts_message`],
/// [`joint_reactions_message`] and [`solver_message`] (`time` first, then
/// the fields in the same order, numbers formatted by serde_json's own
/// formatter, non-finite values left out), without building a
/// `serde_json::Value` per frame. The member names are escaped once, here.
///
/// Names are not checked here; [`StatoptChannels::specs`] checks them when
/// the log is created.
#[derive(Debug, Clone)]
pub struct MessageEncoder {
    coordinates: Vec<Box<[u8]>>,
    activations: Vec<Box<[u8]>>,
    forces: Vec<Box<[u8]>>,
    contacts: Vec<Box<[u8]>>,
    joints: Vec<Box<[u8]>>,
}

/// `"name":` with the name escaped as serde_json escapes strings.
fn json_key(name: &str) -> Box<[u8]> {
    let mut key = serde_json::to_vec(name).expect("a string serializes");
    key.push(b':');
    key.into_boxed_slice()
}

/// Appends `v` as serde_json writes an f64 (the caller checks finiteness).
fn push_number(out: &mut Vec<u8>, v: f64) {
    use serde_json::ser::Formatter;
    // Writing to a Vec cannot fail.
    let _ = serde_json::ser::CompactFormatter.write_f64(out, v);
}

/// Appends `{"time":t` (a message's opening and its time field).
fn open_message(out: &mut Vec<u8>, t: f64) {
    out.extend_from_slice(b"{\"time\":");
    if t.is_finite() {
        push_number(out, t);
    } else {
        // What `json!(t)` holds for a non-finite t (the log rejects it).
        out.extend_from_slice(b"null");
    }
}

/// Appends `,key value` when `v` is finite (JSON has no NaN or infinity);
/// `first` says whether this would be the object's first member.
fn push_member(out: &mut Vec<u8>, first: &mut bool, key: &[u8], v: f64) {
    if v.is_finite() {
        if !*first {
            out.push(b',');
        }
        *first = false;
        out.extend_from_slice(key);
        push_number(out, v);
    }
}

/// Appends the object `{key: value, …}` of the finite values.
fn push_named_numbers(
    out: &mut Vec<u8>,
    what: &str,
    keys: &[Box<[u8]>],
    values: &[f64],
) -> Result<()> {
    if keys.len() != values.len() {
        return Err(Error::internal(format!(
            "{what}: {} names but {} values",
            keys.len(),
            values.len()
        )));
    }
    out.push(b'{');
    let mut first = true;
    for (key, &v) in keys.iter().zip(values) {
        push_member(out, &mut first, key, v);
    }
    out.push(b'}');
    Ok(())
}

/// Appends `{"x":…,"y":…,"z":…}` (finite components only).
fn push_vec3(out: &mut Vec<u8>, v: &[f64; 3]) {
    out.push(b'{');
    let mut first = true;
    push_member(out, &mut first, b"\"x\":", v[0]);
    push_member(out, &mut first, b"\"y\":", v[1]);
    push_member(out, &mut first, b"\"z\":", v[2]);
    out.push(b'}');
}

/// Room for a message of `n` numbers under `keys` (a number takes at most
/// 24 bytes as serde_json writes it), so that it is written without
/// growing the buffer.
fn reserve_for(out: &mut Vec<u8>, keys: &[Box<[u8]>], numbers_per_key: usize, extra: usize) {
    let key_bytes: usize = keys.iter().map(|k| k.len()).sum();
    out.reserve(32 + extra + key_bytes + keys.len() * numbers_per_key * 26);
}

impl MessageEncoder {
    /// An encoder for the messages of `channels`.
    pub fn new(channels: &StatoptChannels) -> MessageEncoder {
        let keys = |v: &[String]| v.iter().map(|n| json_key(n)).collect();
        MessageEncoder {
            coordinates: keys(&channels.coordinates),
            activations: keys(&channels.activations),
            forces: keys(&channels.forces),
            contacts: keys(&channels.contacts),
            joints: keys(&channels.joints),
        }
    }

    /// Appends the `/kinematics` message at time `t` to `out`.
    pub fn kinematics(
        &self,
        out: &mut Vec<u8>,
        t: f64,
        q: &[f64],
        qdot: &[f64],
        qddot: &[f64],
    ) -> Result<()> {
        reserve_for(out, &self.coordinates, 3, 24);
        open_message(out, t);
        out.extend_from_slice(b",\"q\":");
        push_named_numbers(out, "/kinematics q", &self.coordinates, q)?;
        out.extend_from_slice(b",\"qdot\":");
        push_named_numbers(out, "/kinematics qdot", &self.coordinates, qdot)?;
        out.extend_from_slice(b",\"qddot\":");
        push_named_numbers(out, "/kinematics qddot", &self.coordinates, qddot)?;
        out.push(b'}');
        Ok(())
    }

    /// Appends `{"time", key: value, …}` of the finite values.
    fn named_values(out: &mut Vec<u8>, keys: &[Box<[u8]>], t: f64, values: &[f64]) -> Result<()> {
        if keys.len() != values.len() {
            return Err(Error::internal(format!(
                "named values: {} names but {} values",
                keys.len(),
                values.len()
            )));
        }
        reserve_for(out, keys, 1, 0);
        open_message(out, t);
        let mut first = false; // after "time"
        for (key, &v) in keys.iter().zip(values) {
            push_member(out, &mut first, key, v);
        }
        out.push(b'}');
        Ok(())
    }

    /// Appends the `/activations` message at time `t` to `out`.
    pub fn activations(&self, out: &mut Vec<u8>, t: f64, values: &[f64]) -> Result<()> {
        Self::named_values(out, &self.activations, t, values)
    }

    /// Appends the `/muscle_forces` message at time `t` to `out`.
    pub fn muscle_forces(&self, out: &mut Vec<u8>, t: f64, values: &[f64]) -> Result<()> {
        Self::named_values(out, &self.forces, t, values)
    }

    /// Appends the `/contacts` message at time `t` to `out`.
    pub fn contacts(&self, out: &mut Vec<u8>, t: f64, samples: &[ContactSample]) -> Result<()> {
        if self.contacts.len() != samples.len() {
            return Err(Error::internal(format!(
                "/contacts: {} names but {} samples",
                self.contacts.len(),
                samples.len()
            )));
        }
        reserve_for(out, &self.contacts, 9, 120 * samples.len());
        open_message(out, t);
        for (key, c) in self.contacts.iter().zip(samples) {
            out.push(b',');
            out.extend_from_slice(key);
            out.extend_from_slice(b"{\"force\":");
            push_vec3(out, &c.force);
            out.extend_from_slice(b",\"point\":");
            push_vec3(out, &c.point);
            let mut first = false;
            push_member(out, &mut first, b"\"distance\":", c.distance);
            push_member(out, &mut first, b"\"weight\":", c.weight);
            push_member(out, &mut first, b"\"slip_speed\":", c.slip_speed);
            out.extend_from_slice(b",\"regime\":");
            let _ = serde_json::to_writer(&mut *out, c.regime.as_str());
            out.push(b'}');
        }
        out.push(b'}');
        Ok(())
    }

    /// Appends the `/joint_reactions` message at time `t` to `out`.
    pub fn joint_reactions(
        &self,
        out: &mut Vec<u8>,
        t: f64,
        samples: &[JointReactionSample],
    ) -> Result<()> {
        if self.joints.len() != samples.len() {
            return Err(Error::internal(format!(
                "/joint_reactions: {} names but {} samples",
                self.joints.len(),
                samples.len()
            )));
        }
        reserve_for(out, &self.joints, 6, 32 * samples.len());
        open_message(out, t);
        for (key, r) in self.joints.iter().zip(samples) {
            out.push(b',');
            out.extend_from_slice(key);
            out.extend_from_slice(b"{\"force\":");
            push_vec3(out, &r.force);
            out.extend_from_slice(b",\"moment\":");
            push_vec3(out, &r.moment);
            out.push(b'}');
        }
        out.push(b'}');
        Ok(())
    }

    /// Appends the `/solver` message at time `t` to `out`.
    #[allow(clippy::too_many_arguments)]
    pub fn solver(
        &self,
        out: &mut Vec<u8>,
        t: f64,
        status: &str,
        solver: &str,
        iterations: u32,
        objective: f64,
        residual: f64,
        solve_time: Duration,
    ) {
        out.reserve(160 + status.len() + solver.len());
        open_message(out, t);
        out.extend_from_slice(b",\"status\":");
        let _ = serde_json::to_writer(&mut *out, status);
        out.extend_from_slice(b",\"solver\":");
        let _ = serde_json::to_writer(&mut *out, solver);
        out.extend_from_slice(b",\"iterations\":");
        let _ = serde_json::to_writer(&mut *out, &iterations);
        let mut first = false;
        push_member(out, &mut first, b"\"objective\":", objective);
        push_member(out, &mut first, b"\"residual\":", residual);
        let ms = solve_time.as_secs_f64() * 1e3;
        push_member(out, &mut first, b"\"solve_time_ms\":", ms);
        out.push(b'}');
    }
}
