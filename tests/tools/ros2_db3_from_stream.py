#!/usr/bin/env python3
"""Writes a rosbag2 sqlite3 bag folder (OUT/metadata.yaml, OUT/NAME_0.db3 with
NAME the folder's name) from the CDR messages session_to_ros2.mjs streams to
stdin: a first JSON line {"topics": [{name, type, serialization_format,
offered_qos_profiles}]}, then one JSON line a message {"topic", "timestamp"
(ns, a string: beyond a double's integers), "data" (hex)} in log-time order.

Python's standard sqlite3 is the independent writer (node 20 has no
node:sqlite). The tables are rosbag2's sqlite3 storage (Humble, schema
version 3), as tests/core/io/ros2/make_ros2_db3.py writes them; rows are
inserted in the order they come, ids from 1, as rosbag2 does while recording.

usage: session_to_ros2.mjs ... --format sqlite  (spawns: ros2_db3_from_stream.py OUT)
"""
import json
import os
import sqlite3
import sys


def main():
    bag = sys.argv[1]
    name = os.path.basename(os.path.normpath(bag))
    os.makedirs(bag, exist_ok=True)
    db_name = f"{name}_0.db3"
    db_path = os.path.join(bag, db_name)
    if os.path.exists(db_path):
        os.remove(db_path)
    topics = json.loads(sys.stdin.readline())["topics"]
    db = sqlite3.connect(db_path)
    db.executescript("""
        CREATE TABLE schema(schema_version INTEGER PRIMARY KEY, ros_distro TEXT NOT NULL);
        INSERT INTO schema VALUES (3, 'humble');
        CREATE TABLE metadata(id INTEGER PRIMARY KEY, metadata_version INTEGER NOT NULL,
                              metadata TEXT NOT NULL);
        CREATE TABLE topics(id INTEGER PRIMARY KEY, name TEXT NOT NULL, type TEXT NOT NULL,
                            serialization_format TEXT NOT NULL,
                            offered_qos_profiles TEXT NOT NULL);
        CREATE TABLE messages(id INTEGER PRIMARY KEY, topic_id INTEGER NOT NULL,
                              timestamp INTEGER NOT NULL, data BLOB NOT NULL);
        CREATE INDEX timestamp_idx ON messages (timestamp ASC);
    """)
    topic_ids = {}
    for i, t in enumerate(topics, start=1):
        topic_ids[t["name"]] = i
        db.execute("INSERT INTO topics VALUES (?, ?, ?, ?, ?)",
                   (i, t["name"], t["type"], t["serialization_format"], t["offered_qos_profiles"]))
    counts = {t["name"]: 0 for t in topics}
    span = [None, None]

    def rows():
        for line in sys.stdin:
            m = json.loads(line)
            ts = int(m["timestamp"])
            counts[m["topic"]] += 1
            span[0] = ts if span[0] is None else min(span[0], ts)
            span[1] = ts if span[1] is None else max(span[1], ts)
            yield (topic_ids[m["topic"]], ts, bytes.fromhex(m["data"]))

    db.executemany("INSERT INTO messages(topic_id, timestamp, data) VALUES (?, ?, ?)", rows())
    db.commit()
    db.close()
    first, last = span[0] or 0, span[1] or 0
    total = sum(counts.values())
    with open(os.path.join(bag, "metadata.yaml"), "w") as f:
        f.write("rosbag2_bagfile_information:\n"
                "  version: 5\n"
                "  storage_identifier: sqlite3\n"
                f"  duration:\n    nanoseconds: {last - first}\n"
                f"  starting_time:\n    nanoseconds_since_epoch: {first}\n"
                f"  message_count: {total}\n"
                "  topics_with_message_count:\n")
        for t in topics:
            f.write("    - topic_metadata:\n"
                    f"        name: {t['name']}\n"
                    f"        type: {t['type']}\n"
                    f"        serialization_format: {t['serialization_format']}\n"
                    f"        offered_qos_profiles: {json.dumps(t['offered_qos_profiles'])}\n"
                    f"      message_count: {counts[t['name']]}\n")
        f.write("  compression_format: \"\"\n"
                "  compression_mode: \"\"\n"
                "  relative_file_paths:\n"
                f"    - {db_name}\n"
                "  files:\n"
                f"    - path: {db_name}\n"
                f"      starting_time:\n        nanoseconds_since_epoch: {first}\n"
                f"      duration:\n        nanoseconds: {last - first}\n"
                f"      message_count: {total}\n")


if __name__ == "__main__":
    main()
