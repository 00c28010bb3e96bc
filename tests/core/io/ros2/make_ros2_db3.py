#!/usr/bin/env python3
"""Writes a rosbag2 sqlite3 bag (folder with metadata.yaml and one .db3) from
the CDR message bytes that make_ros2_bags.mjs dumped to messages.json.

Uses only Python's standard library (sqlite3, through
tests/tools/rosbag2_sqlite.py), so the .db3 comes from an independent writer.
The tables are rosbag2's (storage plugin sqlite3, schema version 3):
topics(id, name, type, serialization_format, offered_qos_profiles) and
messages(id, topic_id, timestamp, data), plus the schema and metadata tables
newer rosbag2 versions add. Messages are inserted in a shuffled order
(fixed), so readers must ORDER BY timestamp to see them in log-time order.

Usage: make_ros2_db3.py OUT_DIR   (reads OUT_DIR/messages.json, writes
OUT_DIR/sqlite_bag/)
"""
import base64
import json
import os
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "..", "tools"))
import rosbag2_sqlite  # noqa: E402  (tests/tools/rosbag2_sqlite.py)


def main():
    out_dir = sys.argv[1]
    with open(os.path.join(out_dir, "messages.json")) as f:
        dump = json.load(f)
    bag = os.path.join(out_dir, "sqlite_bag")
    os.makedirs(bag, exist_ok=True)
    db_path = os.path.join(bag, "sqlite_bag_0.db3")
    db, topic_ids = rosbag2_sqlite.create(db_path, dump["topics"])
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
    counts = {t["name"]: sum(1 for m in msgs if m["topic"] == t["name"]) for t in dump["topics"]}
    rosbag2_sqlite.write_metadata(bag, "sqlite_bag_0.db3", dump["topics"], counts, first, last)
    print(f"wrote {len(msgs)} messages to {db_path}")


if __name__ == "__main__":
    main()
