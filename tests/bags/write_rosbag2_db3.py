#!/usr/bin/python3
"""Writes rosbag2 sqlite3 bags following rosbag2_storage_sqlite3's schemas, for bags_test.

usage: write_rosbag2_db3.py OUT_DIR
  OUT_DIR/db3_old/   the older schema (topics with offered_qos_profiles; no schema, metadata or
                     message_definitions tables), split over two files, with metadata.yaml
  OUT_DIR/db3_new/   the current schema (schema, metadata, message_definitions tables,
                     type_description_hash), one file, with metadata.yaml
  OUT_DIR/db3.json   {bag folder: [messages in log-time order, ties in write order]}
No npm package writes rosbag2 sqlite3 (@foxglove/rosbag2 reads), so Python's sqlite3 writes the
tables exactly as rosbag2 creates them.
"""
import json
import sqlite3
import struct
import sys

OLD_SCHEMA = [
    "CREATE TABLE topics(id INTEGER PRIMARY KEY,name TEXT NOT NULL,type TEXT NOT NULL,"
    "serialization_format TEXT NOT NULL,offered_qos_profiles TEXT NOT NULL)",
    "CREATE TABLE messages(id INTEGER PRIMARY KEY,topic_id INTEGER NOT NULL,"
    "timestamp INTEGER NOT NULL, data BLOB NOT NULL)",
    "CREATE INDEX timestamp_idx ON messages (timestamp ASC)",
]
NEW_SCHEMA = [
    "CREATE TABLE schema(schema_version INTEGER PRIMARY KEY, ros_distro TEXT NOT NULL)",
    "CREATE TABLE metadata(id INTEGER PRIMARY KEY, metadata_version INTEGER NOT NULL, metadata TEXT NOT NULL)",
    "CREATE TABLE topics(id INTEGER PRIMARY KEY, name TEXT NOT NULL, type TEXT NOT NULL, "
    "serialization_format TEXT NOT NULL, offered_qos_profiles TEXT NOT NULL, "
    "type_description_hash TEXT NOT NULL)",
    "CREATE TABLE message_definitions(id INTEGER PRIMARY KEY, topic_type TEXT NOT NULL, "
    "encoding TEXT NOT NULL, encoded_message_definition TEXT NOT NULL, "
    "type_description_hash TEXT NOT NULL)",
    "CREATE TABLE messages(id INTEGER PRIMARY KEY,topic_id INTEGER NOT NULL,"
    "timestamp INTEGER NOT NULL, data BLOB NOT NULL)",
    "CREATE INDEX timestamp_idx ON messages (timestamp ASC)",
]
TOPICS = [(1, "/chatter", "std_msgs/msg/String"), (2, "/odom_like", "std_msgs/msg/Float64MultiArray")]


def cdr_string(text):
    body = text.encode() + b"\0"
    return b"\x00\x01\x00\x00" + struct.pack("<I", len(body)) + body


def cdr_doubles(values):
    # layout (dim sequence empty, data_offset 0), then the float64 sequence aligned to 8 after
    # the 4-byte encapsulation header
    out = b"\x00\x01\x00\x00" + struct.pack("<II", 0, 0) + struct.pack("<I", len(values))
    out += b"\0" * ((8 - (len(out) - 4) % 8) % 8)
    return out + b"".join(struct.pack("<d", v) for v in values)


def messages():
    """(topic id, timestamp, data) in write order; some written after later ones."""
    out = []
    base = 1700000000 * 10**9
    for i in range(30):
        out.append((1, base + i * 10**8, cdr_string("hello %d" % i)))
        out.append((2, base + i * 10**8 + 5, cdr_doubles([0.5 * i, -1.0, 2.0 ** i])))
    out.append((1, base + 3, cdr_string("late")))
    out.append((1, base + 10**8, cdr_string("same time as hello 1, written later")))
    return out


def write(path, schema, rows, new):
    db = sqlite3.connect(path)
    for statement in schema:
        db.execute(statement)
    if new:
        db.execute("INSERT INTO schema VALUES (4, 'jazzy')")
        for topic_id, name, type_name in TOPICS:
            db.execute("INSERT INTO topics VALUES (?, ?, ?, 'cdr', '', 'RIHS01_00')",
                       (topic_id, name, type_name))
            db.execute("INSERT INTO message_definitions (topic_type, encoding, "
                       "encoded_message_definition, type_description_hash) VALUES (?, 'ros2msg', ?, '')",
                       (type_name, "string data\n" if "String" in type_name else "float64[] data\n"))
    else:
        for topic_id, name, type_name in TOPICS:
            db.execute("INSERT INTO topics VALUES (?, ?, ?, 'cdr', '')", (topic_id, name, type_name))
    for topic_id, timestamp, data in rows:
        db.execute("INSERT INTO messages (topic_id, timestamp, data) VALUES (?, ?, ?)",
                   (topic_id, timestamp, data))
    db.commit()
    db.close()


def metadata(folder, files, count):
    with open("%s/metadata.yaml" % folder, "w") as f:
        f.write("rosbag2_bagfile_information:\n  version: 5\n  storage_identifier: sqlite3\n"
                "  relative_file_paths:\n")
        for name in files:
            f.write("    - %s\n" % name)
        f.write("  message_count: %d\n  compression_format: ''\n  compression_mode: ''\n" % count)


def main():
    import os
    out = sys.argv[1]
    rows = messages()
    names = dict((t[0], t) for t in TOPICS)
    expected = [{"order": i, "topic": names[r[0]][1], "type": names[r[0]][2], "time_ns": r[1],
                 "data": r[2].hex()} for i, r in enumerate(rows)]
    expected.sort(key=lambda m: (m["time_ns"], m["order"]))
    os.makedirs("%s/db3_old" % out, exist_ok=True)
    os.makedirs("%s/db3_new" % out, exist_ok=True)
    # Split by write order: the files overlap in time (late rows are in the second).
    write("%s/db3_old/db3_old_0.db3" % out, OLD_SCHEMA, rows[:40], False)
    write("%s/db3_old/db3_old_1.db3" % out, OLD_SCHEMA, rows[40:], False)
    metadata("%s/db3_old" % out, ["db3_old_0.db3", "db3_old_1.db3"], len(rows))
    write("%s/db3_new/db3_new_0.db3" % out, NEW_SCHEMA, rows, True)
    metadata("%s/db3_new" % out, ["db3_new_0.db3"], len(rows))
    with open("%s/db3.json" % out, "w") as f:
        json.dump({"db3_old": expected, "db3_new": expected}, f)


if __name__ == "__main__":
    main()
