#!/usr/bin/env python3
"""Check an MCAP file written by statopt (src/output/mcap_log).

Opens the file with the `mcap` package, decodes every message as JSON and
validates it against its channel's JSON Schema (with the `jsonschema`
package when it is installed; otherwise only JSON decoding and schema
parsing are checked, and a note says so). It also checks the time rule
log_time = publish_time = round((time - t0) * 1e9) ns, with t0 from the
"statopt.time_origin" metadata record, and per-channel sequence numbers.

A complete file is read through its summary. A file without footer (a run
killed midway) is an error unless --allow-truncated is given: it is then
read linearly up to the last complete record and the messages of its
complete chunks are checked.

Prints per-channel message counts; exits 1 on any failure, 0 otherwise.

Usage: check_mcap.py FILE.mcap [--allow-truncated] [--max-errors N]
"""

import argparse
import json
import sys
from collections import OrderedDict

try:
    from mcap.reader import make_reader
    from mcap.stream_reader import StreamReader
    from mcap.records import Channel, Message, Metadata, Schema
except ImportError:  # pragma: no cover
    sys.exit("check_mcap.py needs the `mcap` package (pip install mcap zstandard)")

try:
    import jsonschema
except ImportError:
    jsonschema = None

TIME_ORIGIN = "statopt.time_origin"


def read_complete(f):
    """All records of a complete file, through its summary."""
    reader = make_reader(f)
    summary = reader.get_summary()
    if summary is None:
        raise ValueError("file has no summary section")
    metadata = {m.name: m.metadata for m in reader.iter_metadata()}
    messages = (m for (_, _, m) in reader.iter_messages(log_time_order=False))
    return summary.schemas, summary.channels, metadata, messages, summary.statistics


def read_linear(f):
    """Records of a possibly truncated file, in file order, up to the first
    unreadable one. Returns the same tuple as read_complete plus the error
    that ended the read (or None)."""
    schemas, channels, metadata, messages = {}, {}, {}, []
    end = None
    try:
        for record in StreamReader(f, skip_magic=False).records:
            if isinstance(record, Schema):
                schemas[record.id] = record
            elif isinstance(record, Channel):
                channels[record.id] = record
            elif isinstance(record, Metadata):
                metadata[record.name] = record.metadata
            elif isinstance(record, Message):
                messages.append(record)
    except Exception as e:  # the truncated tail
        end = e
    return schemas, channels, metadata, iter(messages), None, end


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("file")
    ap.add_argument("--allow-truncated", action="store_true",
                    help="accept a file without footer (killed run): check its complete chunks")
    ap.add_argument("--max-errors", type=int, default=20, help="stop printing after this many errors")
    args = ap.parse_args()

    errors = []

    def fail(msg):
        errors.append(msg)
        if len(errors) <= args.max_errors:
            print("ERROR:", msg)

    truncated_by = None
    stats = None
    with open(args.file, "rb") as f:
        try:
            schemas, channels, metadata, messages, stats = read_complete(f)
            messages = list(messages)
        except Exception as e:
            if not args.allow_truncated:
                print(f"ERROR: {args.file} is not a complete MCAP file ({type(e).__name__}: {e}); "
                      "use --allow-truncated to check the chunks of a killed run")
                return 1
            f.seek(0)
            schemas, channels, metadata, messages, stats, truncated_by = read_linear(f)
            messages = list(messages)
            print(f"note: incomplete file ({type(e).__name__}: {e}); read linearly")

    if jsonschema is None:
        print("note: `jsonschema` not installed; messages are only checked to be JSON objects")

    # Schemas must be JSON and valid JSON Schemas.
    validators = {}
    for sid, s in schemas.items():
        if s.encoding != "jsonschema":
            fail(f"schema {s.name}: encoding {s.encoding!r}, expected 'jsonschema'")
            continue
        try:
            doc = json.loads(s.data)
        except ValueError as e:
            fail(f"schema {s.name}: not JSON: {e}")
            continue
        if jsonschema is not None:
            cls = jsonschema.validators.validator_for(doc, default=jsonschema.Draft202012Validator)
            try:
                cls.check_schema(doc)
            except jsonschema.SchemaError as e:
                fail(f"schema {s.name}: invalid JSON Schema: {e.message}")
                continue
            validators[sid] = cls(doc)
        else:
            validators[sid] = None

    t0 = None
    if TIME_ORIGIN in metadata:
        try:
            t0 = float(metadata[TIME_ORIGIN]["t0"])
        except (KeyError, ValueError) as e:
            fail(f"metadata {TIME_ORIGIN}: bad t0: {e}")
    else:
        print(f"note: no {TIME_ORIGIN} metadata; time stamps not checked")

    counts = OrderedDict()
    for cid in sorted(channels):
        counts[cid] = 0
    last_seq = {}
    for m in messages:
        ch = channels.get(m.channel_id)
        if ch is None:
            fail(f"message on unknown channel {m.channel_id}")
            continue
        counts[m.channel_id] = counts.get(m.channel_id, 0) + 1
        where = f"{ch.topic} #{m.sequence}"
        if ch.message_encoding != "json":
            fail(f"{ch.topic}: message encoding {ch.message_encoding!r}, expected 'json'")
            continue
        try:
            msg = json.loads(m.data)
        except ValueError as e:
            fail(f"{where}: not JSON: {e}")
            continue
        if not isinstance(msg, dict):
            fail(f"{where}: not a JSON object")
            continue
        if ch.schema_id not in schemas:
            fail(f"{where}: channel has no schema")
        elif validators.get(ch.schema_id) is not None:
            for err in validators[ch.schema_id].iter_errors(msg):
                path = "/".join(str(p) for p in err.absolute_path)
                fail(f"{where}: {path or '<root>'}: {err.message}")
        t = msg.get("time")
        if not isinstance(t, (int, float)):
            fail(f"{where}: no numeric time field")
        elif t0 is not None:
            expected = (t - t0) * 1e9
            if abs(m.log_time - expected) > 1.0 or m.publish_time != m.log_time:
                fail(f"{where}: log_time {m.log_time} / publish_time {m.publish_time}, "
                     f"expected round(({t} - {t0}) * 1e9)")
        prev = last_seq.get(m.channel_id)
        if prev is not None and m.sequence != prev + 1:
            fail(f"{where}: sequence follows {prev}")
        last_seq[m.channel_id] = m.sequence

    total = sum(counts.values())
    if stats is not None:
        if stats.message_count != total:
            fail(f"statistics say {stats.message_count} messages, read {total}")
        for cid, n in counts.items():
            if stats.channel_message_counts.get(cid, 0) != n:
                fail(f"statistics say {stats.channel_message_counts.get(cid, 0)} messages on "
                     f"{channels[cid].topic}, read {n}")

    print(f"{args.file}: {len(channels)} channels, {len(schemas)} schemas, {total} messages"
          + (" (truncated file: complete chunks only)" if truncated_by is not None or stats is None else ""))
    if truncated_by is not None:
        print(f"  linear read ended at: {type(truncated_by).__name__}: {truncated_by}")
    for cid, n in counts.items():
        ch = channels[cid]
        sname = schemas[ch.schema_id].name if ch.schema_id in schemas else "-"
        print(f"  {ch.topic:<20} {sname:<24} {n:>7} messages")
    if jsonschema is not None:
        from importlib.metadata import version
        print(f"validated with jsonschema {version('jsonschema')}")
    else:
        print("not validated against schemas (jsonschema missing)")
    if errors:
        print(f"FAILED: {len(errors)} error(s)")
        return 1
    print("OK")
    return 0


if __name__ == "__main__":
    sys.exit(main())
