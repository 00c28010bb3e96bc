#!/usr/bin/env python3
"""Writes a rosbag2 sqlite3 bag (folder with metadata.yaml and one .db3) from
the CDR message bytes that make_ros2_bags.mjs dumped to messages.json.

Uses only Python's standard library (sqlite3), so the .db3 comes from an
independent writer. The tables are rosbag2's (storage plugin sqlite3, schema
version 3): topics(id, name, type, serialization_format, offered_qos_profiles)
and messages(id, topic_id, timestamp, data), plus the schema and metadata
tables newer rosbag2 versions add. Messages are inserted in a shuffled order
(fixed), so readers must ORDER BY timestamp to see them in log-time order.

Usage: make_ros2_db3.py OUT_DIR   (reads OUT_DIR/messages.json, writes
OUT_DIR/sqlite_bag/)
"""
import base64
import json
import os
import sqlite3
import sys


def main():
    out_dir = sys.argv[1]
    with open(os.path.join(out_dir, "messages.json")) as f:
        dump = json.load(f)
    bag = os.path.join(out_dir, "sqlite_bag")
    os.makedirs(bag, exist_ok=True)
    db_path = os.path.join(bag, "sqlite_bag_0.db3")
    if os.path.exists(db_path):
        os.remove(db_path)
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
    for i, t in enumerate(dump["topics"]):
        topic_ids[t["name"]] = i + 1
        db.execute("INSERT INTO topics VALUES (?, ?, ?, ?, ?)",
                   (i + 1, t["name"], t["type"], t["serialization_format"],
                    t["offered_qos_profiles"]))
    msgs = dump["messages"]
    # A fixed shuffle: odd positions first, then even ones in reverse.
    order = list(range(1, len(msgs), 2)) + list(range(len(msgs) - 1 - (len(msgs) - 1) % 2, -1, -2))
    assert sorted(order) == list(range(len(msgs)))
    for row_id, i in enumerate(order, start=1):
        m = msgs[i]
        db.execute("INSERT INTO messages VALUES (?, ?, ?, ?)",
                   (row_id, topic_ids[m["topic"]], int(m["timestamp"]),
                    base64.b64decode(m["data"])))
    db.commit()
    db.close()
    first, last = int(msgs[0]["timestamp"]), int(msgs[-1]["timestamp"])
    with open(os.path.join(bag, "metadata.yaml"), "w") as f:
        f.write("rosbag2_bagfile_information:\n"
                "  version: 5\n"
                "  storage_identifier: sqlite3\n"
                f"  duration:\n    nanoseconds: {last - first}\n"
                f"  starting_time:\n    nanoseconds_since_epoch: {first}\n"
                f"  message_count: {len(msgs)}\n"
                "  topics_with_message_count:\n")
        for t in dump["topics"]:
            count = sum(1 for m in msgs if m["topic"] == t["name"])
            f.write("    - topic_metadata:\n"
                    f"        name: {t['name']}\n"
                    f"        type: {t['type']}\n"
                    "        serialization_format: cdr\n"
                    "        offered_qos_profiles: \"- history: 3\\n  depth: 0\\n\"\n"
                    f"      message_count: {count}\n")
        f.write("  compression_format: \"\"\n"
                "  compression_mode: \"\"\n"
                "  relative_file_paths:\n"
                "    - sqlite_bag_0.db3\n"
                "  files:\n"
                "    - path: sqlite_bag_0.db3\n"
                f"      starting_time:\n        nanoseconds_since_epoch: {first}\n"
                f"      duration:\n        nanoseconds: {last - first}\n"
                f"      message_count: {len(msgs)}\n")
    print(f"wrote {len(msgs)} messages to {db_path}")


if __name__ == "__main__":
    main()
