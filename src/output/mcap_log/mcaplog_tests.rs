//! Tests of the MCAP log. Files are read back with the `mcap` crate's own
//! readers; expected values are the messages the tests themselves log and
//! closed-form time stamps.

use super::*;
use mcap::read::Options as ReadOptions;
use std::collections::HashMap;

/// A scratch file, removed when dropped (`STATOPT_KEEP_TEST_FILES=1`
/// keeps it, to run `scripts/check_mcap.py` on it afterwards).
fn scratch(name: &str) -> crate::test_dir::TempFile {
    crate::test_dir::TempFile::new("mcaplog", name)
}

fn arm_like() -> StatoptChannels {
    let s = |v: &[&str]| v.iter().map(|x| x.to_string()).collect::<Vec<_>>();
    StatoptChannels {
        coordinates: s(&["r_shoulder_elev", "r_elbow_flex"]),
        activations: s(&[
            "TRIlong",
            "TRIlat",
            "TRImed",
            "BIClong",
            "BICshort",
            "BRA",
            "r_shoulder_elev_reserve",
        ]),
        forces: s(&[
            "TRIlong",
            "TRIlat",
            "TRImed",
            "BIClong",
            "BICshort",
            "BRA",
            "r_shoulder_elev_reserve",
        ]),
        contacts: s(&["hand_contact", "elbow_contact"]),
        joints: s(&["r_shoulder", "r_elbow"]),
    }
}

fn strs(v: &[String]) -> Vec<&str> {
    v.iter().map(String::as_str).collect()
}

/// Frame k's time: padded data starting before zero.
fn frame_time(k: usize) -> f64 {
    -0.05 + 0.01 * k as f64
}

/// All messages of frame `k` as (channel index, message without `time`).
fn frame_messages(layout: &StatoptChannels, k: usize) -> Vec<(usize, Value)> {
    let x = k as f64;
    let coords = strs(&layout.coordinates);
    let n = coords.len();
    let q: Vec<f64> = (0..n).map(|i| (0.1 * x + i as f64).sin()).collect();
    let qd: Vec<f64> = (0..n).map(|i| (0.1 * x + i as f64).cos()).collect();
    let mut qdd: Vec<f64> = (0..n).map(|i| -(0.1 * x + i as f64).sin() / 3.0).collect();
    if k == 7 {
        // A non-finite value must be left out, not written as invalid JSON.
        qdd[1] = f64::NAN;
    }
    let acts = strs(&layout.activations);
    let a: Vec<f64> = (0..acts.len())
        .map(|i| 0.5 + 0.4 * (0.05 * x + i as f64).sin())
        .collect();
    let f: Vec<f64> = a.iter().map(|v| v * 1234.5678).collect();
    let contacts = strs(&layout.contacts);
    let samples: Vec<ContactSample> = (0..contacts.len())
        .map(|i| ContactSample {
            force: [x, -2.0 * x + i as f64, 1.0 / (x + 1.0)],
            point: [0.1 * i as f64, 0.2, -0.3],
            distance: -1e-3 * x,
            weight: 1.0 / 3.0,
            slip_speed: if k % 2 == 0 { 0.0 } else { 0.25 },
            regime: if k % 2 == 0 { "static" } else { "kinetic" }.to_string(),
        })
        .collect();
    let joints = strs(&layout.joints);
    let reactions: Vec<JointReactionSample> = (0..joints.len())
        .map(|i| JointReactionSample {
            force: [x, i as f64, -x],
            moment: [0.5, -0.5 * x, 1e-12 * x],
        })
        .collect();
    vec![
        (
            KINEMATICS,
            kinematics_message(&coords, &q, &qd, &qdd).expect("kinematics"),
        ),
        (
            ACTIVATIONS,
            named_values_message(&acts, &a).expect("activations"),
        ),
        (
            MUSCLE_FORCES,
            named_values_message(&strs(&layout.forces), &f).expect("forces"),
        ),
        (
            CONTACTS,
            contacts_message(&contacts, &samples).expect("contacts"),
        ),
        (
            JOINT_REACTIONS,
            joint_reactions_message(&joints, &reactions).expect("joints"),
        ),
        (
            SOLVER,
            solver_message(
                if k % 10 == 3 {
                    "AlmostSolved"
                } else {
                    "Solved"
                },
                if k % 7 == 2 { "clarabel" } else { "newton" },
                (k % 17) as u32,
                x * x,
                1e-13 * x,
                Duration::from_micros(150 + k as u64),
            ),
        ),
    ]
}

/// `msg` with `time` added first, as `McapLog::log` writes it.
fn with_time(t: f64, msg: &Value) -> Value {
    let mut m = Map::new();
    m.insert("time".into(), json!(t));
    for (k, v) in msg.as_object().expect("object") {
        m.insert(k.clone(), v.clone());
    }
    Value::Object(m)
}

/// A validator for the subset of JSON Schema written here (type, properties,
/// additionalProperties: false, required, items, minItems/maxItems,
/// minimum). scripts/check_mcap.py validates with the full `jsonschema`.
fn validate(schema: &Value, v: &Value, path: &str) -> std::result::Result<(), String> {
    if let Some(ty) = schema.get("type").and_then(Value::as_str) {
        let ok = match ty {
            "object" => v.is_object(),
            "number" => v.is_number(),
            "integer" => v.is_u64() || v.is_i64(),
            "string" => v.is_string(),
            "array" => v.is_array(),
            other => return Err(format!("{path}: schema type {other} not handled")),
        };
        if !ok {
            return Err(format!("{path}: {v} is not of type {ty}"));
        }
    }
    if let Some(min) = schema.get("minimum").and_then(Value::as_f64) {
        if v.as_f64().is_some_and(|x| x < min) {
            return Err(format!("{path}: {v} < {min}"));
        }
    }
    if let Some(obj) = v.as_object() {
        let props = schema.get("properties").and_then(Value::as_object);
        for (k, val) in obj {
            match props.and_then(|p| p.get(k)) {
                Some(s) => validate(s, val, &format!("{path}.{k}"))?,
                None => {
                    if schema.get("additionalProperties") == Some(&Value::Bool(false)) {
                        return Err(format!("{path}: unexpected field {k}"));
                    }
                }
            }
        }
        for r in schema
            .get("required")
            .and_then(Value::as_array)
            .into_iter()
            .flatten()
        {
            let r = r.as_str().ok_or("required entry not a string")?;
            if !obj.contains_key(r) {
                return Err(format!("{path}: missing required field {r}"));
            }
        }
    }
    if let Some(arr) = v.as_array() {
        let n = arr.len() as u64;
        if let Some(min) = schema.get("minItems").and_then(Value::as_u64) {
            if n < min {
                return Err(format!("{path}: {n} items < {min}"));
            }
        }
        if let Some(max) = schema.get("maxItems").and_then(Value::as_u64) {
            if n > max {
                return Err(format!("{path}: {n} items > {max}"));
            }
        }
        if let Some(items) = schema.get("items") {
            for (i, x) in arr.iter().enumerate() {
                validate(items, x, &format!("{path}[{i}]"))?;
            }
        }
    }
    Ok(())
}

/// Writes `frames` frames of the statopt channel set plus a generic
/// `object_schema` channel; returns the specs and, in order, every
/// (channel index, time, message with time) logged.
fn write_statopt_log(
    path: &Path,
    frames: usize,
    options: LogOptions,
) -> (Vec<ChannelSpec>, Vec<(usize, f64, Value)>, McapLog) {
    let layout = arm_like();
    let mut specs = layout.specs().expect("specs");
    specs.push(ChannelSpec {
        topic: "/generic".into(),
        schema_name: "test.Generic".into(),
        schema: object_schema("test.Generic", &["a", "b"], &[("v", 3)]),
    });
    let generic = specs.len() - 1;
    let mut log = McapLog::create_with_options(path, &specs, options).expect("create");
    let mut written = Vec::new();
    for k in 0..frames {
        let t = frame_time(k);
        let mut msgs = frame_messages(&layout, k);
        msgs.push((
            generic,
            json!({"a": k as f64 * 0.5, "b": -(k as f64), "v": [1.0, 2.0, k as f64]}),
        ));
        for (idx, msg) in msgs {
            log.log(idx, t, &msg).expect("log");
            written.push((idx, t, with_time(t, &msg)));
        }
    }
    (specs, written, log)
}

#[test]
fn mcaplog_time_rule_closed_form() {
    assert_eq!(time_to_ns(-0.05, -0.05), Some(0));
    assert_eq!(time_to_ns(1.0, -0.5), Some(1_500_000_000));
    // round to nearest: 0.4 ns → 0, 0.6 ns → 1, a tiny negative rounds to 0.
    assert_eq!(time_to_ns(0.4e-9, 0.0), Some(0));
    assert_eq!(time_to_ns(0.6e-9, 0.0), Some(1));
    assert_eq!(time_to_ns(-1e-12, 0.0), Some(0));
    assert_eq!(time_to_ns(-1e-9, 0.0), None);
    assert_eq!(time_to_ns(f64::NAN, 0.0), None);
    assert_eq!(time_to_ns(1e11, 0.0), None); // 1e20 ns > u64::MAX
}

/// Test 1: ~1000 messages on 7 channels, read back through the summary and
/// the message stream.
#[test]
fn mcaplog_round_trip() {
    let path = scratch("roundtrip.mcap");
    let frames = 150; // 7 channels → 1050 messages
    let (specs, written, log) = write_statopt_log(&path, frames, LogOptions::default());
    log.finish().expect("finish");
    println!("wrote {}", path.display());

    let bytes = std::fs::read(&path).expect("read back");
    let summary = mcap::Summary::read(&bytes)
        .expect("summary parses")
        .expect("summary present");

    // Channels and schemas.
    assert_eq!(summary.channels.len(), specs.len());
    let mut channel_of_topic = HashMap::new();
    for ch in summary.channels.values() {
        let spec = specs
            .iter()
            .find(|s| s.topic == ch.topic)
            .unwrap_or_else(|| panic!("unexpected topic {}", ch.topic));
        assert_eq!(ch.message_encoding, "json");
        let schema = ch.schema.as_ref().expect("channel has a schema");
        assert_eq!(schema.name, spec.schema_name);
        assert_eq!(schema.encoding, "jsonschema");
        let parsed: Value = serde_json::from_slice(&schema.data).expect("schema is JSON");
        assert_eq!(parsed, spec.schema);
        assert_eq!(parsed["$schema"], JSON_SCHEMA_DIALECT);
        channel_of_topic.insert(ch.topic.clone(), ch.id);
    }

    // Statistics: per-channel counts.
    let stats = summary.stats.as_ref().expect("statistics");
    assert_eq!(stats.message_count, written.len() as u64);
    assert_eq!(stats.channel_count as usize, specs.len());
    for (i, spec) in specs.iter().enumerate() {
        let expected = written.iter().filter(|w| w.0 == i).count() as u64;
        assert_eq!(expected, frames as u64);
        let id = channel_of_topic[&spec.topic];
        assert_eq!(
            stats.channel_message_counts[&id], expected,
            "{}",
            spec.topic
        );
    }
    assert_eq!(stats.message_start_time, 0);
    // Last frame: t − t0 = 0.01 · 149 s.
    assert!((stats.message_end_time as i64 - 1_490_000_000).abs() <= 1);

    // Chunks are uncompressed by default.
    assert!(!summary.chunk_indexes.is_empty());
    for c in &summary.chunk_indexes {
        assert_eq!(c.compression, "");
        assert_eq!(c.compressed_size, c.uncompressed_size);
    }

    // Time origin metadata.
    assert_eq!(summary.metadata_indexes.len(), 1);
    let meta = mcap::read::metadata(&bytes, &summary.metadata_indexes[0]).expect("metadata");
    assert_eq!(meta.name, TIME_ORIGIN_METADATA);
    assert_eq!(meta.metadata["t0"].parse::<f64>().ok(), Some(frame_time(0)));

    // Every message, in order, round-trips and validates.
    let messages: Vec<_> = mcap::MessageStream::new(&bytes)
        .expect("stream")
        .collect::<std::result::Result<_, _>>()
        .expect("all messages read");
    assert_eq!(messages.len(), written.len());
    let mut last_seq: HashMap<u16, u32> = HashMap::new();
    for (m, (idx, t, expected)) in messages.iter().zip(&written) {
        assert_eq!(m.channel.topic, specs[*idx].topic);
        let got: Value = serde_json::from_slice(&m.data).expect("message is JSON");
        assert_eq!(&got, expected);
        assert_eq!(got["time"].as_f64(), Some(*t));
        // Frame k is at k · 10 ms after t0.
        let k = ((t - frame_time(0)) / 0.01).round();
        assert!(
            (m.log_time as f64 - k * 1e7).abs() <= 1.0,
            "{} vs {k}",
            m.log_time
        );
        assert_eq!(m.publish_time, m.log_time);
        validate(&specs[*idx].schema, &got, &m.channel.topic).unwrap_or_else(|e| panic!("{e}"));
        if let Some(prev) = last_seq.insert(m.channel.id, m.sequence) {
            assert_eq!(m.sequence, prev + 1);
        }
    }
    // Activations are named scalars addressable as /activations.TRIlong.
    let a = &written[ACTIVATIONS].2;
    assert!(a["TRIlong"].is_number());
    // The NaN of frame 7 was left out, and the message still validates.
    let k7 = written
        .iter()
        .find(|w| w.0 == KINEMATICS && w.1 == frame_time(7))
        .expect("frame 7");
    assert!(k7.2["qddot"].get("r_elbow_flex").is_none());
    assert!(k7.2["qddot"]["r_shoulder_elev"].is_number());
}

/// The subset validator used above must reject what the schemas forbid.
#[test]
fn mcaplog_schemas_reject_wrong_messages() {
    let specs = arm_like().specs().expect("specs");
    let act = &specs[ACTIVATIONS].schema;
    assert!(validate(act, &json!({"time": 0.0, "TRIlong": 0.2}), "a").is_ok());
    assert!(validate(act, &json!({"time": 0.0, "NOTAMUSCLE": 0.2}), "a").is_err());
    assert!(validate(act, &json!({"TRIlong": 0.2}), "a").is_err());
    assert!(validate(act, &json!({"time": 0.0, "TRIlong": "x"}), "a").is_err());
    let solver = &specs[SOLVER].schema;
    assert!(validate(solver, &json!({"time": 0.0, "iterations": 3}), "s").is_err());
    assert!(validate(
        solver,
        &json!({"time": 0.0, "status": "Solved", "iterations": 2.5}),
        "s"
    )
    .is_err());
    let generic = object_schema("g", &["a"], &[("v", 2)]);
    assert!(validate(&generic, &json!({"time": 0.0, "a": 1, "v": [1, 2]}), "g").is_ok());
    assert!(validate(&generic, &json!({"time": 0.0, "a": 1, "v": [1]}), "g").is_err());
}

/// Reads `bytes` as a possibly truncated MCAP with the linear reader;
/// returns the messages read before the first error and whether there was
/// an error.
fn read_lenient(bytes: &[u8]) -> (Vec<(String, u64, Value)>, bool) {
    let mut out = Vec::new();
    let stream =
        match mcap::MessageStream::new_with_options(bytes, ReadOptions::IgnoreEndMagic.into()) {
            Ok(s) => s,
            Err(_) => return (out, true),
        };
    for m in stream {
        match m {
            Ok(m) => out.push((
                m.channel.topic.clone(),
                m.log_time,
                serde_json::from_slice(&m.data).expect("complete messages are JSON"),
            )),
            Err(_) => return (out, true),
        }
    }
    (out, false)
}

/// Test 2: a run killed midway. The file is copied from disk while the log
/// is still open (what SIGKILL would leave: the process's file writes, no
/// summary or footer); its complete chunks must be readable.
#[test]
fn mcaplog_killed_midway_leaves_complete_chunks() {
    let path = scratch("killed_midway_source.mcap");
    let chunk_size = 4 * 1024;
    let options = LogOptions {
        chunk_size,
        max_chunk_age: None,
        ..LogOptions::default()
    };
    let frames = 40; // 280 messages, ~100 kB uncompressed → many chunks
    let (specs, written, log) = write_statopt_log(&path, frames, options);
    let killed = std::fs::read(&path).expect("copy of the file mid-run");
    let killed_path = scratch("killed_midway.mcap");
    std::fs::write(&killed_path, &killed).expect("write killed copy");
    println!(
        "killed-run image: {} ({} bytes)",
        killed_path.display(),
        killed.len()
    );

    // No footer, so no summary.
    assert!(
        mcap::Summary::read(&killed).is_err()
            || mcap::Summary::read(&killed).ok().flatten().is_none()
    );
    assert!(mcap::MessageStream::new(&killed)
        .map(|s| s.collect::<std::result::Result<Vec<_>, _>>().is_err())
        .unwrap_or(true));

    let (got, _) = read_lenient(&killed);
    // A non-empty prefix of what was logged, and at most the open chunk lost.
    assert!(!got.is_empty());
    assert!(
        got.len() < written.len(),
        "the open chunk is not on disk yet"
    );
    for (g, (idx, _, expected)) in got.iter().zip(&written) {
        assert_eq!(g.0, specs[*idx].topic);
        assert_eq!(&g.2, expected);
    }
    let lost_bytes: usize = written[got.len()..]
        .iter()
        .map(|w| serde_json::to_vec(&w.2).expect("json").len())
        .sum();
    // The open chunk closes once it exceeds chunk_size (message records add
    // 31 bytes of header each).
    let largest = written
        .iter()
        .map(|w| serde_json::to_vec(&w.2).expect("json").len() + 31)
        .max()
        .expect("messages");
    assert!(
        lost_bytes as u64 <= chunk_size + largest as u64,
        "lost {lost_bytes} bytes of messages"
    );
    println!(
        "killed midway: {} of {} messages readable ({} lost with the open chunk)",
        got.len(),
        written.len(),
        written.len() - got.len()
    );

    // flush() puts everything on disk; dropping without finish() then
    // still completes the file (mcap's Drop writes summary and footer).
    let mut log = log;
    log.flush().expect("flush");
    let flushed = std::fs::read(&path).expect("read");
    assert_eq!(read_lenient(&flushed).0.len(), written.len());
    drop(log);
    let dropped = std::fs::read(&path).expect("read");
    let summary = mcap::Summary::read(&dropped)
        .expect("summary")
        .expect("present");
    assert_eq!(
        summary.stats.expect("stats").message_count,
        written.len() as u64
    );
}

/// A kill can also tear the write of a chunk. Cutting a finished file at
/// every byte position must give a prefix of the messages, never a panic,
/// and all messages of the chunks wholly before the cut.
#[test]
fn mcaplog_truncated_anywhere_reads_a_prefix() {
    let path = scratch("truncated_source.mcap");
    let options = LogOptions {
        chunk_size: 2 * 1024,
        max_chunk_age: None,
        ..LogOptions::default()
    };
    let (_specs, written, log) = write_statopt_log(&path, 12, options);
    log.finish().expect("finish");
    let bytes = std::fs::read(&path).expect("read");
    let summary = mcap::Summary::read(&bytes)
        .expect("summary")
        .expect("present");
    let mut chunks = summary.chunk_indexes.clone();
    chunks.sort_by_key(|c| c.chunk_start_offset);
    assert!(chunks.len() >= 5, "{} chunks", chunks.len());
    // (end offset, message count) of each chunk, from the summary.
    let chunk_ends: Vec<(usize, usize)> = chunks
        .iter()
        .map(|c| {
            let n = summary.stream_chunk(&bytes, c).expect("chunk").count();
            ((c.chunk_start_offset + c.chunk_length) as usize, n)
        })
        .collect();
    assert_eq!(chunk_ends.iter().map(|c| c.1).sum::<usize>(), written.len());
    let mut prev_len = 0usize;
    for cut in 8..bytes.len() {
        let (got, _) = read_lenient(&bytes[..cut]);
        assert!(got.len() <= written.len());
        for (g, w) in got.iter().zip(&written) {
            assert_eq!(g.2, w.2, "cut at {cut}");
        }
        assert!(
            got.len() >= prev_len,
            "cut at {cut}: fewer messages than a shorter cut"
        );
        prev_len = got.len();
        // Every chunk that ends before the cut is fully read.
        let complete: usize = chunk_ends.iter().filter(|c| c.0 <= cut).map(|c| c.1).sum();
        assert!(
            got.len() >= complete,
            "cut at {cut}: {} < {complete}",
            got.len()
        );
    }
    assert_eq!(prev_len, written.len());
}

#[test]
fn mcaplog_errors_name_the_file() {
    let specs = vec![solver_channel()];
    let bad = Path::new("/nonexistent-dir-statopt/x.mcap");
    let e = McapLog::create(bad, &specs).err().expect("must fail");
    assert!(
        e.to_string().contains("/nonexistent-dir-statopt/x.mcap"),
        "{e}"
    );

    let path = scratch("errors.mcap");
    let dup = vec![solver_channel(), solver_channel()];
    assert!(McapLog::create(&path, &dup).is_err());

    let mut log = McapLog::create(&path, &specs).expect("create");
    let msg = solver_message("Solved", "newton", 1, 0.0, 0.0, Duration::ZERO);
    log.log(0, 1.0, &msg).expect("first");
    let e = log.log(0, 0.5, &msg).err().expect("before t0");
    assert!(e.to_string().contains("errors.mcap"), "{e}");
    assert!(log.log(0, f64::NAN, &msg).is_err());
    assert!(log.log(1, 1.0, &msg).is_err());
    assert!(log.log(0, 1.0, &json!([1, 2])).is_err());
    assert!(log.log(0, 1.0, &json!({"time": 2.0})).is_err());
    assert_eq!(log.time_origin(), Some(1.0));
    log.log(0, 1.5, &msg).expect("later");
    log.finish().expect("finish");

    assert!(activations_channel(&["a", "a"]).is_err());
    assert!(activations_channel(&["time"]).is_err());
    assert!(contacts_channel(&[""]).is_err());
    assert!(named_values_message(&["a"], &[1.0, 2.0]).is_err());
}

#[test]
fn mcaplog_explicit_time_origin() {
    let path = scratch("origin.mcap");
    let specs = vec![activations_channel(&["m"]).expect("spec")];
    let mut log = McapLog::create(&path, &specs).expect("create");
    log.set_time_origin(-1.0).expect("origin");
    assert!(log.set_time_origin(0.0).is_err());
    let msg = named_values_message(&["m"], &[0.5]).expect("msg");
    log.log(0, -0.25, &msg).expect("log");
    log.finish().expect("finish");
    let bytes = std::fs::read(&path).expect("read");
    let m: Vec<_> = mcap::MessageStream::new(&bytes)
        .expect("stream")
        .collect::<std::result::Result<_, _>>()
        .expect("read");
    assert_eq!(m.len(), 1);
    assert_eq!(m[0].log_time, 750_000_000);
}

/// The direct encoder writes exactly the bytes of `serialize_message` on the
/// `Value` messages: every channel, with non-finite values (left out),
/// -0.0, subnormal, huge and tiny numbers, and names that need escaping.
#[test]
fn message_encoder_equals_serialized_values() {
    let mut layout = arm_like();
    layout.coordinates.push("quote\"back\\slash".to_string());
    layout.activations.push("ünïcode\u{1}".to_string());
    layout.forces.push("ünïcode\u{1}".to_string());
    layout.contacts.push("tab\tcontact".to_string());
    let enc = MessageEncoder::new(&layout);
    let mut state = 0x9E3779B97F4A7C15u64;
    let mut next = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        state
    };
    let mut value = move || {
        let r = next();
        match r % 10 {
            0 => f64::NAN,
            1 => f64::INFINITY,
            2 => -0.0,
            3 => f64::from_bits(r >> 12), // subnormal
            4 => f64::from_bits(r),       // any
            5 => (r >> 40) as f64,
            _ => ((r >> 11) as f64 / (1u64 << 53) as f64 - 0.5) * 10f64.powi((r % 40) as i32 - 20),
        }
    };
    let same = |what: &str, got: &[u8], t: f64, v: &Value| {
        let want = serialize_message(t, v).expect("serialize");
        assert_eq!(
            String::from_utf8_lossy(got),
            String::from_utf8_lossy(&want),
            "{what} at t = {t}"
        );
    };
    let mut out = Vec::new();
    for k in 0..3000 {
        let t = if k % 100 == 0 { -0.0 } else { frame_time(k) };
        // The test's own frames, then random values.
        if k < 50 {
            for (idx, msg) in frame_messages(&arm_like(), k) {
                let names = arm_like();
                let e = MessageEncoder::new(&names);
                out.clear();
                let o = msg.as_object().expect("object");
                let nums = |field: &str, keys: &[String]| -> Vec<f64> {
                    keys.iter()
                        .map(|n| o[field][n].as_f64().unwrap_or(f64::NAN))
                        .collect()
                };
                match idx {
                    KINEMATICS => e
                        .kinematics(
                            &mut out,
                            t,
                            &nums("q", &names.coordinates),
                            &nums("qdot", &names.coordinates),
                            &nums("qddot", &names.coordinates),
                        )
                        .expect("kinematics"),
                    ACTIVATIONS | MUSCLE_FORCES => {
                        let v: Vec<f64> = names
                            .activations
                            .iter()
                            .map(|n| o[n].as_f64().unwrap_or(f64::NAN))
                            .collect();
                        if idx == ACTIVATIONS {
                            e.activations(&mut out, t, &v).expect("activations")
                        } else {
                            e.muscle_forces(&mut out, t, &v).expect("forces")
                        }
                    }
                    _ => continue, // random values below cover the rest
                }
                same("frame message", &out, t, &msg);
            }
        }
        let coords = strs(&layout.coordinates);
        let n = coords.len();
        let (q, qd, qdd): (Vec<f64>, Vec<f64>, Vec<f64>) = (
            (0..n).map(|_| value()).collect(),
            (0..n).map(|_| value()).collect(),
            (0..n).map(|_| value()).collect(),
        );
        out.clear();
        enc.kinematics(&mut out, t, &q, &qd, &qdd).expect("kin");
        same(
            "kinematics",
            &out,
            t,
            &kinematics_message(&coords, &q, &qd, &qdd).expect("kin"),
        );
        let acts = strs(&layout.activations);
        let a: Vec<f64> = (0..acts.len()).map(|_| value()).collect();
        out.clear();
        enc.activations(&mut out, t, &a).expect("act");
        same(
            "activations",
            &out,
            t,
            &named_values_message(&acts, &a).expect("act"),
        );
        out.clear();
        enc.muscle_forces(&mut out, t, &a).expect("forces");
        same(
            "forces",
            &out,
            t,
            &named_values_message(&acts, &a).expect("forces"),
        );
        let contacts = strs(&layout.contacts);
        let samples: Vec<ContactSample> = (0..contacts.len())
            .map(|i| ContactSample {
                force: [value(), value(), value()],
                point: [value(), value(), value()],
                distance: value(),
                weight: value(),
                slip_speed: value(),
                regime: ["static", "kinetic", "blended", "odd\"one"][(k + i) % 4].to_string(),
            })
            .collect();
        out.clear();
        enc.contacts(&mut out, t, &samples).expect("contacts");
        same(
            "contacts",
            &out,
            t,
            &contacts_message(&contacts, &samples).expect("c"),
        );
        let joints = strs(&layout.joints);
        let reactions: Vec<JointReactionSample> = (0..joints.len())
            .map(|_| JointReactionSample {
                force: [value(), value(), value()],
                moment: [value(), value(), value()],
            })
            .collect();
        out.clear();
        enc.joint_reactions(&mut out, t, &reactions).expect("jr");
        same(
            "joint reactions",
            &out,
            t,
            &joint_reactions_message(&joints, &reactions).expect("jr"),
        );
        let (status, solver, it) = (
            ["Solved", "AlmostSolved", "Failed\\x"][k % 3],
            "newton",
            k as u32 * 977,
        );
        let (obj, res) = (value(), value());
        let dt = Duration::from_nanos(next_u64(k));
        out.clear();
        enc.solver(&mut out, t, status, solver, it, obj, res, dt);
        same(
            "solver",
            &out,
            t,
            &solver_message(status, solver, it, obj, res, dt),
        );
    }
    // Wrong lengths are errors, as for the Value builders.
    assert!(enc.activations(&mut out, 0.0, &[1.0]).is_err());
    assert!(enc
        .kinematics(&mut out, 0.0, &[1.0], &[1.0], &[1.0])
        .is_err());
    assert!(enc.contacts(&mut out, 0.0, &[]).is_err());
    assert!(enc.joint_reactions(&mut out, 0.0, &[]).is_err());
}

fn next_u64(k: usize) -> u64 {
    (k as u64).wrapping_mul(0x9E3779B97F4A7C15) >> 20
}

/// With zstd asked for, the chunks are zstd, compress, and read back.
#[test]
fn mcaplog_zstd_chunks_compress_and_read_back() {
    let path = scratch("zstd.mcap");
    let options = LogOptions {
        compression: ChunkCompression::Zstd,
        ..LogOptions::default()
    };
    let (_specs, written, log) = write_statopt_log(&path, 60, options);
    log.finish().expect("finish");
    let bytes = std::fs::read(&path).expect("read back");
    let summary = mcap::Summary::read(&bytes)
        .expect("summary parses")
        .expect("summary present");
    assert!(!summary.chunk_indexes.is_empty());
    for c in &summary.chunk_indexes {
        assert_eq!(c.compression, "zstd");
        assert!(c.compressed_size < c.uncompressed_size / 2);
    }
    let messages: Vec<_> = mcap::MessageStream::new(&bytes)
        .expect("stream")
        .collect::<std::result::Result<_, _>>()
        .expect("all messages read");
    assert_eq!(messages.len(), written.len());
    for (m, (_, _, expected)) in messages.iter().zip(&written) {
        let got: Value = serde_json::from_slice(&m.data).expect("JSON message");
        assert_eq!(&got, expected);
    }
}
