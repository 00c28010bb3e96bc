// Writes the ROS 2 test bags under tests/data/ros2/ with independent writers
// (never sweepscan's own code): @mcap/core's McapWriter for the MCAP record
// layer, @foxglove/rosmsg2-serialization's MessageWriter for the CDR message
// bytes (from the ROS 2 .msg definitions below, parsed by @foxglove/rosmsg and
// checked against @foxglove/rosmsg-msgs-common's Humble definitions),
// @foxglove/cdr's CdrWriter for the big-endian samples, @foxglove/wasm-zstd
// and lz4js for chunk compression. It also dumps every message's CDR bytes to
// messages.json, from which make_ros2_db3.py writes the sqlite3 bag.
//
// The message contents are formulas of the message index k (and element index
// i) using only + - * / on exactly representable or decimal constants, so the
// C++ tests recompute the same IEEE doubles and compare field for field
// (tests/core/io/ros2/ros2_test_bags.h mirrors the formulas).
//
// Usage: node make_ros2_bags.mjs OUT_DIR   (scripts/make-ros2-test-bags.sh)
import fs from "node:fs";
import path from "node:path";
import { McapWriter, TempBuffer } from "@mcap/core";
import { parse } from "@foxglove/rosmsg";
import { MessageWriter } from "@foxglove/rosmsg2-serialization";
import { CdrWriter, EncapsulationKind } from "@foxglove/cdr";
import { ros2humble } from "@foxglove/rosmsg-msgs-common";
import zstd from "@foxglove/wasm-zstd";
import lz4 from "lz4js";

const outDir = process.argv[2];
if (!outDir) throw new Error("usage: node make_ros2_bags.mjs OUT_DIR");
fs.mkdirSync(path.join(outDir, "cdr"), { recursive: true });

const SEP = "=".repeat(80) + "\n";
const HEADER = "MSG: std_msgs/Header\nbuiltin_interfaces/Time stamp\nstring frame_id\n";
const TIME = "MSG: builtin_interfaces/Time\nint32 sec\nuint32 nanosec\n";
const VEC3 = "MSG: geometry_msgs/Vector3\nfloat64 x\nfloat64 y\nfloat64 z\n";
const QUAT = "MSG: geometry_msgs/Quaternion\nfloat64 x 0\nfloat64 y 0\nfloat64 z 0\nfloat64 w 1\n";
const POINT = "MSG: geometry_msgs/Point\nfloat64 x\nfloat64 y\nfloat64 z\n";
const deps = (...d) => d.map((s) => SEP + s).join("");
const MSGS = {
  "sensor_msgs/msg/LaserScan":
    "std_msgs/Header header\nfloat32 angle_min\nfloat32 angle_max\nfloat32 angle_increment\n" +
    "float32 time_increment\nfloat32 scan_time\nfloat32 range_min\nfloat32 range_max\n" +
    "float32[] ranges\nfloat32[] intensities\n" + deps(HEADER, TIME),
  "nav_msgs/msg/Odometry":
    "std_msgs/Header header\nstring child_frame_id\ngeometry_msgs/PoseWithCovariance pose\n" +
    "geometry_msgs/TwistWithCovariance twist\n" +
    deps(HEADER, TIME,
      "MSG: geometry_msgs/PoseWithCovariance\ngeometry_msgs/Pose pose\nfloat64[36] covariance\n",
      "MSG: geometry_msgs/Pose\ngeometry_msgs/Point position\ngeometry_msgs/Quaternion orientation\n",
      POINT, QUAT,
      "MSG: geometry_msgs/TwistWithCovariance\ngeometry_msgs/Twist twist\nfloat64[36] covariance\n",
      "MSG: geometry_msgs/Twist\ngeometry_msgs/Vector3 linear\ngeometry_msgs/Vector3 angular\n", VEC3),
  "sensor_msgs/msg/Imu":
    "std_msgs/Header header\ngeometry_msgs/Quaternion orientation\nfloat64[9] orientation_covariance\n" +
    "geometry_msgs/Vector3 angular_velocity\nfloat64[9] angular_velocity_covariance\n" +
    "geometry_msgs/Vector3 linear_acceleration\nfloat64[9] linear_acceleration_covariance\n" +
    deps(HEADER, TIME, QUAT, VEC3),
  "tf2_msgs/msg/TFMessage":
    "geometry_msgs/TransformStamped[] transforms\n" +
    deps("MSG: geometry_msgs/TransformStamped\nstd_msgs/Header header\nstring child_frame_id\n" +
         "geometry_msgs/Transform transform\n",
      HEADER, TIME,
      "MSG: geometry_msgs/Transform\ngeometry_msgs/Vector3 translation\n" +
      "geometry_msgs/Quaternion rotation\n", VEC3, QUAT),
  "std_msgs/msg/String": "string data\n",
};
// The definitions above must match @foxglove/rosmsg-msgs-common's ROS 2
// Humble ones field for field (names, types, array kinds), so the bags carry
// the real message layouts.
const fieldsOf = (defs) => defs.filter((f) => !f.isConstant)
  .map((f) => `${f.type} ${f.name} ${f.isArray ? `[${f.arrayLength ?? ""}]` : ""}`).join("; ");
const writers = {};
for (const [type, text] of Object.entries(MSGS)) {
  const parsed = parse(text, { ros2: true });
  for (const def of parsed) {
    const name = (def.name ?? type).replace("/msg/", "/");
    if (name === "builtin_interfaces/Time") continue;  // a primitive ("time") for the library
    const common = ros2humble[name];
    if (!common || fieldsOf(common.definitions) !== fieldsOf(def.definitions)) {
      throw new Error(`${name}: ${fieldsOf(def.definitions)} != ` +
                      `${common ? fieldsOf(common.definitions) : "(missing)"}`);
    }
  }
  writers[type] = new MessageWriter(parsed);
}

// ---- The known content (mirrored in ros2_test_bags.h) ----
const kBaseSec = 1700000000;
const kLatencyNs = 2000000n;  // log_time = header stamp + 2 ms
const stamp = (ns) => ({ sec: kBaseSec + Math.floor(ns / 1e9), nanosec: ns % 1e9 });
const nsOf = (rel) => BigInt(kBaseSec) * 1000000000n + BigInt(rel);

function scan(k) {
  const n = 9 + k;
  const ranges = new Float32Array(n);
  const intensities = new Float32Array(k % 5 === 4 ? 0 : n);
  for (let i = 0; i < n; i++) ranges[i] = 1 + 0.25 * i + 0.5 * k;
  for (let i = 0; i < intensities.length; i++) intensities[i] = 10 * i + k;
  if (k === 3) { ranges[0] = Infinity; ranges[1] = NaN; }
  return {
    header: { stamp: stamp(k * 100000000), frame_id: "laser" },
    angle_min: -1, angle_max: -1 + (n - 1) * 0.125, angle_increment: 0.125,
    time_increment: 0.0001, scan_time: 0.1, range_min: 0.05, range_max: 12,
    ranges, intensities,
  };
}
function odom(k) {
  const cov = (f) => Array.from({ length: 36 }, (_, i) => f(i));
  return {
    header: { stamp: stamp(k * 200000000 + 50000000), frame_id: "odom" },
    child_frame_id: "base_link",
    pose: {
      pose: { position: { x: 0.5 * k, y: -0.25 * k, z: 0.125 },
              orientation: k % 2 ? { x: 0, y: 0, z: 0.6, w: 0.8 } : { x: 0, y: 0, z: 0, w: 1 } },
      covariance: cov((i) => 0.001 * i + k),
    },
    twist: {
      twist: { linear: { x: 0.25 + 0.01 * k, y: 0, z: 0 }, angular: { x: 0, y: 0, z: -0.125 * k } },
      covariance: cov((i) => 0.002 * i - k),
    },
  };
}
function imu(k) {
  const cov = (f) => Array.from({ length: 9 }, (_, i) => f(i));
  return {
    header: { stamp: stamp(k * 200000000 + 10000000), frame_id: "imu_link" },
    orientation: { x: 0.1 * k, y: 0.2, z: 0.3, w: 0.9 },
    orientation_covariance: k % 2 ? cov((i) => (i === 0 ? -1 : 0)) : cov((i) => 0.01 * (i + 1)),
    angular_velocity: { x: 0.01 * k, y: -0.02 * k, z: 0.03 * k },
    angular_velocity_covariance: cov((i) => 0.0001 * i),
    linear_acceleration: { x: 0.1, y: 0.2, z: 9.81 },
    linear_acceleration_covariance: cov((i) => 0.001 * i),
  };
}
const tfStatic = () => ({
  transforms: [
    { header: { stamp: stamp(0), frame_id: "base_link" }, child_frame_id: "laser",
      transform: { translation: { x: 0.1, y: 0, z: 0.2 }, rotation: { x: 0, y: 0, z: 0, w: 1 } } },
    { header: { stamp: stamp(0), frame_id: "base_link" }, child_frame_id: "imu_link",
      transform: { translation: { x: -0.05, y: 0.01, z: 0.1 },
                   rotation: { x: 0, y: 0, z: 0.7071067811865476, w: 0.7071067811865476 } } },
  ],
});
const tf = (k) => ({
  transforms: [{ header: { stamp: stamp(k * 400000000 + 30000000), frame_id: "odom" },
                 child_frame_id: "base_link",
                 transform: { translation: { x: 0.5 * k, y: -0.25 * k, z: 0 },
                              rotation: { x: 0, y: 0, z: 0, w: 1 } } }],
});

const TOPICS = [
  { name: "/scan", type: "sensor_msgs/msg/LaserScan" },
  { name: "/odom", type: "nav_msgs/msg/Odometry" },
  { name: "/imu", type: "sensor_msgs/msg/Imu" },
  { name: "/tf", type: "tf2_msgs/msg/TFMessage" },
  { name: "/tf_static", type: "tf2_msgs/msg/TFMessage" },
  { name: "/chatter", type: "std_msgs/msg/String" },
];
const QOS = "- history: 3\n  depth: 0\n  reliability: 1\n  durability: 2\n";
const messages = [];  // { topic, logTime (bigint), data }
const add = (topic, relNs, msg) => {
  const type = TOPICS.find((t) => t.name === topic).type;
  messages.push({ topic, logTime: nsOf(relNs) + kLatencyNs, data: writers[type].writeMessage(msg) });
};
add("/tf_static", -1000000, tfStatic());  // logged 1 ms before the first scan: no ties
for (let k = 0; k < 20; k++) add("/scan", k * 100000000, scan(k));
for (let k = 0; k < 10; k++) add("/odom", k * 200000000 + 50000000, odom(k));
for (let k = 0; k < 10; k++) add("/imu", k * 200000000 + 10000000, imu(k));
for (let k = 0; k < 5; k++) add("/tf", k * 400000000 + 30000000, tf(k));
for (let k = 0; k < 3; k++) add("/chatter", k * 500000000 + 70000000, { data: `hello ${k}` });
messages.sort((a, b) => (a.logTime < b.logTime ? -1 : a.logTime > b.logTime ? 1 : 0));

async function writeMcap(file, msgs, options) {
  const buffer = new TempBuffer();
  const writer = new McapWriter({ writable: buffer, chunkSize: 1024, ...options });
  await writer.start({ profile: "ros2", library: "make_ros2_bags.mjs (@mcap/core 2.2.2)" });
  const channelIds = {};
  for (const t of TOPICS) {
    const schemaId = await writer.registerSchema({
      name: t.type, encoding: "ros2msg", data: new TextEncoder().encode(MSGS[t.type]) });
    channelIds[t.name] = await writer.registerChannel({
      topic: t.name, schemaId, messageEncoding: "cdr",
      metadata: new Map([["offered_qos_profiles", QOS]]) });
  }
  let seq = 0;
  for (const m of msgs) {
    await writer.addMessage({ channelId: channelIds[m.topic], sequence: seq++,
                              logTime: m.logTime, publishTime: m.logTime, data: m.data });
  }
  if (options.withAttachment) {
    await writer.addAttachment({ name: "calibration.txt", mediaType: "text/plain",
      logTime: nsOf(0), createTime: nsOf(0), data: new TextEncoder().encode("alpha 0.3 mrad\n") });
    await writer.addMetadata({ name: "rosbag2", metadata: new Map([["ros_distro", "humble"]]) });
  }
  await writer.end();
  fs.writeFileSync(path.join(outDir, file), buffer.get());
}

await zstd.isLoaded;
const zstdChunk = (data) => ({ compression: "zstd", compressedData: zstd.compress(data, 3) });
const lz4Chunk = (data) => ({ compression: "lz4", compressedData: lz4.compress(data) });
// Full summary (statistics, chunk indexes, summary offsets), zstd chunks.
await writeMcap("ros2_zstd.mcap", messages, { compressChunk: zstdChunk, withAttachment: true });
// lz4 chunks and no summary section at all: readers must scan.
await writeMcap("ros2_lz4_nosummary.mcap", messages, {
  compressChunk: lz4Chunk, useStatistics: false, useSummaryOffsets: false, useChunkIndex: false,
  useMessageIndex: false, useAttachmentIndex: false, useMetadataIndex: false,
  repeatSchemas: false, repeatChannels: false });
// Messages straight in the data section (no chunks).
await writeMcap("ros2_unchunked.mcap", messages, { useChunks: false });
// A rosbag2 folder split in two MCAP files.
fs.mkdirSync(path.join(outDir, "mcap_bag"), { recursive: true });
const half = Math.floor(messages.length / 2);
await writeMcap("mcap_bag/mcap_bag_0.mcap", messages.slice(0, half), { compressChunk: zstdChunk });
await writeMcap("mcap_bag/mcap_bag_1.mcap", messages.slice(half), { compressChunk: zstdChunk });
fs.writeFileSync(path.join(outDir, "mcap_bag/metadata.yaml"),
  "rosbag2_bagfile_information:\n  version: 5\n  storage_identifier: mcap\n" +
  `  duration:\n    nanoseconds: ${messages.at(-1).logTime - messages[0].logTime}\n` +
  `  starting_time:\n    nanoseconds_since_epoch: ${messages[0].logTime}\n` +
  `  message_count: ${messages.length}\n  topics_with_message_count: []\n` +
  "  compression_format: \"\"\n  compression_mode: \"\"\n" +
  "  relative_file_paths:\n    - mcap_bag_0.mcap\n    - mcap_bag_1.mcap\n" +
  "  files:\n    - path: mcap_bag_0.mcap\n    - path: mcap_bag_1.mcap\n");

// The CDR bytes for make_ros2_db3.py (in log-time order) and single samples.
fs.writeFileSync(path.join(outDir, "messages.json"), JSON.stringify({
  topics: TOPICS.map((t) => ({ ...t, serialization_format: "cdr", offered_qos_profiles: QOS })),
  messages: messages.map((m) => ({ topic: m.topic, timestamp: m.logTime.toString(),
                                   data: Buffer.from(m.data).toString("base64") })),
}, null, 1) + "\n");
const sample = (name, data) => fs.writeFileSync(path.join(outDir, "cdr", name), data);
sample("laserscan_le.cdr", writers["sensor_msgs/msg/LaserScan"].writeMessage(scan(3)));
sample("odometry_le.cdr", writers["nav_msgs/msg/Odometry"].writeMessage(odom(1)));
sample("imu_le.cdr", writers["sensor_msgs/msg/Imu"].writeMessage(imu(2)));
sample("tf_le.cdr", writers["tf2_msgs/msg/TFMessage"].writeMessage(tfStatic()));

// Big-endian (CDR_BE) samples, field by field with @foxglove/cdr.
function headerBe(w, h) { w.int32(h.stamp.sec); w.uint32(h.stamp.nanosec); w.string(h.frame_id); }
{
  const m = scan(7);
  const w = new CdrWriter({ kind: EncapsulationKind.CDR_BE });
  headerBe(w, m.header);
  for (const f of ["angle_min", "angle_max", "angle_increment", "time_increment", "scan_time",
                   "range_min", "range_max"]) w.float32(m[f]);
  w.float32Array(m.ranges, true);
  w.float32Array(m.intensities, true);
  sample("laserscan_be.cdr", w.data);
}
{
  const m = imu(1);
  const w = new CdrWriter({ kind: EncapsulationKind.CDR_BE });
  headerBe(w, m.header);
  const q = m.orientation;
  for (const v of [q.x, q.y, q.z, q.w, ...m.orientation_covariance,
                   m.angular_velocity.x, m.angular_velocity.y, m.angular_velocity.z,
                   ...m.angular_velocity_covariance,
                   m.linear_acceleration.x, m.linear_acceleration.y, m.linear_acceleration.z,
                   ...m.linear_acceleration_covariance]) w.float64(v);
  sample("imu_be.cdr", w.data);
}
{
  const m = tfStatic();
  const w = new CdrWriter({ kind: EncapsulationKind.CDR_BE });
  w.sequenceLength(m.transforms.length);
  for (const t of m.transforms) {
    headerBe(w, t.header);
    w.string(t.child_frame_id);
    const { translation: v, rotation: q } = t.transform;
    for (const x of [v.x, v.y, v.z, q.x, q.y, q.z, q.w]) w.float64(x);
  }
  sample("tf_be.cdr", w.data);
}
{
  const m = odom(3);
  const w = new CdrWriter({ kind: EncapsulationKind.CDR_BE });
  headerBe(w, m.header);
  w.string(m.child_frame_id);
  const p = m.pose.pose, t = m.twist.twist;
  for (const x of [p.position.x, p.position.y, p.position.z, p.orientation.x, p.orientation.y,
                   p.orientation.z, p.orientation.w, ...m.pose.covariance,
                   t.linear.x, t.linear.y, t.linear.z, t.angular.x, t.angular.y, t.angular.z,
                   ...m.twist.covariance]) w.float64(x);
  sample("odometry_be.cdr", w.data);
}
console.log(`wrote ${messages.length} messages to ${outDir}`);
