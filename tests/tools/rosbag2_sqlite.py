"""rosbag2's sqlite3 storage (Humble, schema version 3), written with Python's
standard sqlite3 so that the test bags come from a writer independent of ours
(docs/ros-bags.md). Shared by tests/core/io/ros2/make_ros2_db3.py (the
checked-in bag) and tests/tools/ros2_db3_from_stream.py (bags of simulated
sessions).

A bag is a folder: NAME_0.db3 with the tables below, and metadata.yaml
(rosbag2_bagfile_information version 5) naming it. `topics` are dicts with
name, type, serialization_format and offered_qos_profiles (a YAML string).
"""
import json
import os
import sqlite3

# The statements are stored in the file (sqlite_master) as written, white
# space too: kept as the checked-in bag was made, so that rerunning
# scripts/make-ros2-test-bags.sh leaves its .db3 byte for byte the same.
SCHEMA = """
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
"""


def create(db_path, topics):
    """Makes db_path afresh with rosbag2's tables and the topics (ids from 1,
    in order). Returns the open connection and {topic name: id}."""
    if os.path.exists(db_path):
        os.remove(db_path)
    db = sqlite3.connect(db_path)
    db.executescript(SCHEMA)
    topic_ids = {}
    for i, t in enumerate(topics, start=1):
        topic_ids[t["name"]] = i
        db.execute("INSERT INTO topics VALUES (?, ?, ?, ?, ?)",
                   (i, t["name"], t["type"], t["serialization_format"], t["offered_qos_profiles"]))
    return db, topic_ids


def write_metadata(bag, db_name, topics, counts, first, last):
    """bag/metadata.yaml for one file, db_name, holding counts[topic name]
    messages of each topic, stamped first..last (ns)."""
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
