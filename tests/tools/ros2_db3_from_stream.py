#!/usr/bin/env python3
"""Writes a rosbag2 sqlite3 bag folder (OUT/metadata.yaml, OUT/NAME_0.db3 with
NAME the folder's name) from the CDR messages session_to_ros2.mjs streams to
stdin: a first JSON line {"topics": [{name, type, serialization_format,
offered_qos_profiles}]}, then one JSON line a message {"topic", "timestamp"
(ns, a string: beyond a double's integers), "data" (hex)} in log-time order.

Python's standard sqlite3 is the independent writer (node 20 has no
node:sqlite). The tables are rosbag2's sqlite3 storage (Humble, schema
version 3: tests/tools/rosbag2_sqlite.py, which make_ros2_db3.py uses too); rows are
inserted in the order they come, ids from 1, as rosbag2 does while recording.

usage: session_to_ros2.mjs ... --format sqlite  (spawns: ros2_db3_from_stream.py OUT)
"""
import json
import os
import sys

import rosbag2_sqlite  # tests/tools/rosbag2_sqlite.py, beside this file


def main():
    bag = sys.argv[1]
    name = os.path.basename(os.path.normpath(bag))
    os.makedirs(bag, exist_ok=True)
    db_name = f"{name}_0.db3"
    db_path = os.path.join(bag, db_name)
    topics = json.loads(sys.stdin.readline())["topics"]
    db, topic_ids = rosbag2_sqlite.create(db_path, topics)
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
    rosbag2_sqlite.write_metadata(bag, db_name, topics, counts, first, last)


if __name__ == "__main__":
    main()
