// Writes a ROS 2 bag of a sweepscan drive with independent writers (never
// sweepscan's own code), as a robot running ROS 2 would record it: the same
// messages, values, topics and frames as session_to_rosbag1.py writes to a
// ROS 1 bag (read its docstring for the drive's content and the LaserScan
// binning), here as ROS 2 messages:
//
//   /scan        sensor_msgs/msg/LaserScan     /odom  nav_msgs/msg/Odometry
//   /imu/data    sensor_msgs/msg/Imu           /tf    tf2_msgs/msg/TFMessage
//   /tf_static   tf2_msgs/msg/TFMessage (base_footprint -> laser, -> imu_link)
//
// The CDR bytes come from @foxglove/rosmsg2-serialization's MessageWriter,
// on definitions parsed by @foxglove/rosmsg from ROS 2 Humble .msg texts
// (rendered from @foxglove/rosmsg-msgs-common's Humble definitions). The
// container is either
//   --format mcap   (default) a rosbag2-style MCAP file by @mcap/core's
//                   McapWriter: profile ros2, schemas ros2msg, messages cdr,
//                   chunks compressed with --compression zstd|lz4|none
//                   (@foxglove/wasm-zstd, lz4js: as make_ros2_bags.mjs);
//   --format sqlite a rosbag2 sqlite3 bag folder OUT/ (metadata.yaml,
//                   OUT_0.db3) built by ros2_db3_from_stream.py with Python's
//                   sqlite3 (node 20 has no node:sqlite), fed on its stdin.
// Messages are written in log-time order, as rosbag2 records them.
//
// usage: node session_to_ros2.mjs CSV_DIR META_JSON OUT [--format mcap|sqlite]
//        [--compression zstd|lz4|none] [--bins N] [--epoch S] [--intensity]
//        [--drop-imu-orientation] [--scan-frame laser] [--repeat N]
//        [--python PYTHON3]
// Packages: scripts/install-test-tools.sh (npm ci in tests/tools).
import fs from "node:fs";
import path from "node:path";
import { spawn } from "node:child_process";
import { fileURLToPath } from "node:url";
import { parseArgs } from "node:util";
import { McapWriter } from "@mcap/core";
import { parse } from "@foxglove/rosmsg";
import { MessageWriter } from "@foxglove/rosmsg2-serialization";
import { ros2humble } from "@foxglove/rosmsg-msgs-common";
import zstd from "@foxglove/wasm-zstd";
import lz4 from "lz4js";

const { values: opt, positionals } = parseArgs({
  allowPositionals: true,
  options: {
    format: { type: "string", default: "mcap" },
    compression: { type: "string", default: "zstd" },
    bins: { type: "string", default: "7200" },
    epoch: { type: "string", default: "1700000000.0" },
    intensity: { type: "boolean", default: false },
    "drop-imu-orientation": { type: "boolean", default: false },
    "scan-frame": { type: "string", default: "laser" },
    repeat: { type: "string", default: "1" },
    python: { type: "string", default: "python3" },
  },
});
if (positionals.length !== 3 || !["mcap", "sqlite"].includes(opt.format) ||
    !["zstd", "lz4", "none"].includes(opt.compression)) {
  throw new Error("usage: session_to_ros2.mjs CSV_DIR META_JSON OUT [--format mcap|sqlite] " +
                  "[--compression zstd|lz4|none] [--bins N] [--epoch S] [--intensity] " +
                  "[--drop-imu-orientation] [--scan-frame F] [--repeat N] [--python PYTHON3]");
}
const [csvDir, metaPath, out] = positionals;
const bins = Number(opt.bins), epoch = Number(opt.epoch), repeat = Number(opt.repeat);
const scanFrame = opt["scan-frame"];

// ---- ROS 2 message definitions ----
// ROS 2 .msg text of TYPE with its dependencies, as rosbag2 stores a schema;
// the library's Humble definitions spell builtin_interfaces/Time as "time".
function msgText(type) {
  const field = (f) => {
    const t = f.type === "time" ? "builtin_interfaces/Time" : f.type;
    if (f.isConstant) return `${t} ${f.name}=${f.valueText ?? f.value}`;
    const arr = f.isArray ? `[${f.arrayLength ?? ""}]` : "";
    return `${t}${arr} ${f.name}${f.defaultValue !== undefined ? ` ${f.defaultValue}` : ""}`;
  };
  const body = (name) => ros2humble[name].definitions.map(field).join("\n") + "\n";
  const seen = [], queue = [type];
  while (queue.length) {
    for (const f of ros2humble[queue.shift()].definitions) {
      const dep = f.type === "time" ? "builtin_interfaces/Time" : f.isComplex ? f.type : null;
      if (dep && !seen.includes(dep)) { seen.push(dep); queue.push(dep); }
    }
  }
  return body(type) + seen.map((d) => "=".repeat(80) + `\nMSG: ${d}\n` + body(d)).join("");
}
const TOPICS = [  // id order = topic ids of the sqlite bag, channel order of the MCAP file
  { name: "/tf_static", type: "tf2_msgs/TFMessage", durability: 1 },  // transient local (latched)
  { name: "/odom", type: "nav_msgs/Odometry", durability: 2 },
  { name: "/tf", type: "tf2_msgs/TFMessage", durability: 2 },
  { name: "/imu/data", type: "sensor_msgs/Imu", durability: 2 },
  { name: "/scan", type: "sensor_msgs/LaserScan", durability: 2 },
].map((t) => {
  const text = msgText(t.type);
  return {
    ...t, ros2Type: t.type.replace("/", "/msg/"), text,
    writer: new MessageWriter(parse(text, { ros2: true })),
    // rosbag2 (Humble) records each publisher's QoS as YAML: reliable, keep last.
    qos: "- history: 3\n  depth: 0\n  reliability: 1\n" + `  durability: ${t.durability}\n` +
         "  deadline:\n    sec: 2147483647\n    nsec: 4294967295\n" +
         "  lifespan:\n    sec: 2147483647\n    nsec: 4294967295\n  liveliness: 1\n" +
         "  liveliness_lease_duration:\n    sec: 2147483647\n    nsec: 4294967295\n" +
         "  avoid_ros_namespace_conventions: false\n",
  };
});
const topicOf = Object.fromEntries(TOPICS.map((t) => [t.name, t]));

// ---- The drive (session_to_rosbag1.py, line for line) ----
// epoch + t seconds in ns, rounded as Python's int(round(x * 1e9)): the
// product is far above 2^53, so it is already a whole number.
const stampNs = (t) => BigInt((epoch + t) * 1e9);
const rosTime = (ns) => ({ sec: Number(ns / 1000000000n), nanosec: Number(ns % 1000000000n) });
// Python's round(): halves to even.
const pyRound = (x) => {
  const f = Math.floor(x), d = x - f;
  return d < 0.5 ? f : d > 0.5 ? f + 1 : (f % 2 === 0 ? f : f + 1);
};
function quatRpy(roll, pitch, yaw) {  // Rz(yaw) Ry(pitch) Rx(roll) as x, y, z, w
  const cr = Math.cos(roll / 2), sr = Math.sin(roll / 2);
  const cp = Math.cos(pitch / 2), sp = Math.sin(pitch / 2);
  const cy = Math.cos(yaw / 2), sy = Math.sin(yaw / 2);
  return { x: sr * cp * cy - cr * sp * sy, y: cr * sp * cy + sr * cp * sy,
           z: cr * cp * sy - sr * sp * cy, w: cr * cp * cy + sr * sp * sy };
}
const transform = (ns, parent, child, [x, y, z], rotation) => ({
  header: { stamp: rosTime(ns), frame_id: parent }, child_frame_id: child,
  transform: { translation: { x, y, z }, rotation },
});
function readCsv(name) {
  const [head, ...lines] = fs.readFileSync(path.join(csvDir, name), "utf8").split("\n");
  const keys = head.split(",");
  return lines.filter((l) => l.length).map((l) => {
    const v = l.split(",");
    return Object.fromEntries(keys.map((k, i) => [k, Number(v[i])]));
  });
}

const meta = JSON.parse(fs.readFileSync(metaPath, "utf8"));
const robot = meta.robot;
// The scenario's start pose: the odometry frame is the scenario's world.
const start = meta.settings?.scenario?.path?.start ?? {};
const h = robot.lidar_height_m, l1 = robot.lidar_offset_x_m, d = robot.wheel_distance_m;

const scans = new Map();  // scan index -> [t, range, theta]
for (const r of readCsv("lidar.csv")) {
  if (!scans.has(r.scan)) scans.set(r.scan, []);
  scans.get(r.scan).push([r.robot_time_s, r.range_m, r.theta_rad]);
}
const imu = readCsv("imu.csv"), wheels = readCsv("wheels.csv");

const firstT = Math.min(...[...scans.values()].filter((s) => s.length).map((s) => s[0][0]),
                        ...wheels.map((w) => w.robot_time_s));
const t0 = stampNs(firstT);
const inc = 2 * Math.PI / bins;
const msgs = [];  // { logNs, index, topic, msg }
const add = (topic, msg, logNs) => msgs.push({ logNs, index: msgs.length, topic, msg });

// The sweepscan mount as a ROS scan frame: L = Ry(-90 deg) S (docs/ros-bags.md).
const s45 = Math.sqrt(0.5);
add("/tf_static", { transforms: [
  transform(t0, "base_footprint", scanFrame, [l1, 0, h], { x: 0, y: -s45, z: 0, w: s45 }),
  transform(t0, "base_footprint", "imu_link", [robot.imu_offset_x_m, 0, 0.1], { x: 0, y: 0, z: 0, w: 1 }),
] }, t0);

const zeros = (n) => new Array(n).fill(0);
let x = start.x_m ?? 0, y = start.y_m ?? 0, yaw = start.yaw_rad ?? 0, lastT = null;
for (const w of wheels) {
  const t = w.robot_time_s;
  const v = 0.5 * (w.left_mps + w.right_mps), om = (w.right_mps - w.left_mps) / (2 * d);
  if (lastT !== null) {
    const dt = t - lastT;
    x += v * dt * Math.cos(yaw + 0.5 * om * dt);
    y += v * dt * Math.sin(yaw + 0.5 * om * dt);
    yaw += om * dt;
  }
  lastT = t;
  const ns = stampNs(t), q = quatRpy(0, 0, yaw);
  const poseCov = zeros(36), twistCov = zeros(36);
  poseCov[0] = poseCov[7] = 1e-4;
  twistCov[0] = twistCov[35] = 1e-4;
  add("/odom", {
    header: { stamp: rosTime(ns), frame_id: "odom" }, child_frame_id: "base_footprint",
    pose: { pose: { position: { x, y, z: 0 }, orientation: q }, covariance: poseCov },
    twist: { twist: { linear: { x: v, y: 0, z: 0 }, angular: { x: 0, y: 0, z: om } }, covariance: twistCov },
  }, ns);
  add("/tf", { transforms: [transform(ns, "odom", "base_footprint", [x, y, 0], q)] }, ns);
}

for (const r of imu) {
  const ns = stampNs(r.robot_time_s);
  const oCov = zeros(9), wCov = zeros(9), aCov = zeros(9);
  let orientation = { x: 0, y: 0, z: 0, w: 0 };  // ROS 1's default, all zero
  if (opt["drop-imu-orientation"]) {
    oCov[0] = -1;
  } else {
    orientation = quatRpy(r.roll_rad, r.pitch_rad, r.yaw_rad);
    oCov[0] = oCov[4] = oCov[8] = 3e-5;
  }
  wCov[8] = 1e-6;
  aCov[0] = -1;
  add("/imu/data", {
    header: { stamp: rosTime(ns), frame_id: "imu_link" },
    orientation, orientation_covariance: oCov,
    angular_velocity: { x: 0, y: 0, z: r.gyro_z_rad_s }, angular_velocity_covariance: wCov,
    linear_acceleration: { x: 0, y: 0, z: 0 }, linear_acceleration_covariance: aCov,
  }, ns);
}

for (const index of [...scans.keys()].sort((a, b) => a - b)) {
  const samples = scans.get(index).filter((s) => s[1] > 0);  // range 0: no return
  if (samples.length < 2) continue;
  // The turn's angular rate from the first and last sample, hence each bin's time.
  const unwrapped = [];
  let turns = 0, prev = null;
  for (const [, , th] of samples) {
    if (prev !== null && th + turns < prev - Math.PI) turns += 2 * Math.PI;
    unwrapped.push(th + turns);
    prev = th + turns;
  }
  const ta = samples[0][0], tha = unwrapped[0];
  const tb = samples.at(-1)[0], thb = unwrapped.at(-1);
  const rate = (thb - tha) / (tb - ta), period = 2 * Math.PI / rate;
  // The grid runs in time order from the first sample's bin on, past 2 pi
  // if the turn started before angle 0.
  const angleMin = pyRound(tha / inc) * inc;
  const nBins = pyRound((thb - angleMin) / inc) + 1;
  const ranges = new Float32Array(nBins).fill(NaN);
  const intensities = new Float32Array(opt.intensity ? nBins : 0);
  samples.forEach(([, r], k) => {
    const b = pyRound((unwrapped[k] - angleMin) / inc);
    if (b >= 0 && b < nBins && Number.isNaN(ranges[b])) {
      ranges[b] = r;
      if (opt.intensity) intensities[b] = 100 * r;
    }
  });
  add("/scan", {
    header: { stamp: rosTime(stampNs(ta + (angleMin - tha) / rate)), frame_id: scanFrame },
    angle_min: angleMin, angle_max: angleMin + (nBins - 1) * inc, angle_increment: inc,
    time_increment: period / bins, scan_time: period, range_min: 0.12, range_max: 10.0,
    ranges, intensities,
  }, stampNs(tb));
}
msgs.sort((a, b) => (a.logNs < b.logNs ? -1 : a.logNs > b.logNs ? 1 : a.index - b.index));

// --repeat: the drive again and again, each copy shifted by the drive's
// length plus 0.1 s, the shifts rounded as genpy's Duration.from_sec does
// (so the copies sit where session_to_rosbag1.py --repeat puts them).
const fromSec = (s) => BigInt(Math.trunc(s)) * 1000000000n + BigInt(Math.trunc((s - Math.trunc(s)) * 1e9));
const spanNs = msgs.at(-1).logNs - msgs[0].logNs;
const span = Number(spanNs / 1000000000n) + Number(spanNs % 1000000000n) / 1e9 + 0.1;
function* emitted() {  // [topic, log time ns, CDR bytes] in log-time order
  for (let k = 0; k < repeat; k++) {
    const shiftNs = fromSec(k * span), stampShiftNs = BigInt(k) * fromSec(span);
    const shifted = (hdr) => {
      const ns = BigInt(hdr.stamp.sec) * 1000000000n + BigInt(hdr.stamp.nanosec) + stampShiftNs;
      return { ...hdr, stamp: rosTime(ns) };
    };
    for (const { logNs, topic, msg } of msgs) {
      if (k > 0 && topic === "/tf_static") continue;
      let m = msg;
      if (k > 0 && topic === "/tf") {
        m = { transforms: msg.transforms.map((tr) => ({ ...tr, header: shifted(tr.header) })) };
      } else if (k > 0) {
        m = { ...msg, header: shifted(msg.header) };
      }
      yield [topic, logNs + shiftNs, topicOf[topic].writer.writeMessage(m)];
    }
  }
}

// ---- Containers ----
class FileWritable {  // the McapWriter's output straight to the file, not held in memory
  constructor(file) { this.fd = fs.openSync(file, "w"); this.pos = 0n; }
  position() { return this.pos; }
  async write(buf) {
    for (let off = 0; off < buf.byteLength;) off += fs.writeSync(this.fd, buf, off);
    this.pos += BigInt(buf.byteLength);
  }
  close() { fs.closeSync(this.fd); }
}

async function writeMcap() {
  await zstd.isLoaded;
  const compressChunk = {
    zstd: (data) => ({ compression: "zstd", compressedData: zstd.compress(data, 3) }),
    lz4: (data) => ({ compression: "lz4", compressedData: lz4.compress(data) }),
    none: undefined,
  }[opt.compression];
  const file = new FileWritable(out);
  const writer = new McapWriter({ writable: file, compressChunk });
  await writer.start({ profile: "ros2", library: "session_to_ros2.mjs (@mcap/core 2.2.2)" });
  const channel = {}, sequence = {};
  for (const t of TOPICS) {
    const schemaId = await writer.registerSchema({
      name: t.ros2Type, encoding: "ros2msg", data: new TextEncoder().encode(t.text) });
    channel[t.name] = await writer.registerChannel({
      topic: t.name, schemaId, messageEncoding: "cdr",
      metadata: new Map([["offered_qos_profiles", t.qos]]) });
    sequence[t.name] = 0;
  }
  for (const [topic, logNs, data] of emitted()) {
    await writer.addMessage({ channelId: channel[topic], sequence: sequence[topic]++,
                              logTime: logNs, publishTime: logNs, data });
  }
  await writer.end();
  file.close();
}

// The .db3 by Python's sqlite3: a header line (the topics) then one JSON line
// a message, {"topic", "timestamp", "data" (hex)}, streamed to its stdin.
async function writeSqlite() {
  const script = path.join(path.dirname(fileURLToPath(import.meta.url)), "ros2_db3_from_stream.py");
  const py = spawn(opt.python, [script, out], { stdio: ["pipe", "inherit", "inherit"] });
  const done = new Promise((resolve, reject) => {
    py.on("error", reject);
    py.on("close", (code) => (code === 0 ? resolve() : reject(new Error(`${script} exited with ${code}`))));
  });
  const send = (line) => (py.stdin.write(line + "\n") ? null : new Promise((r) => py.stdin.once("drain", r)));
  await send(JSON.stringify({ topics: TOPICS.map((t) => ({
    name: t.name, type: t.ros2Type, serialization_format: "cdr", offered_qos_profiles: t.qos })) }));
  for (const [topic, logNs, data] of emitted()) {
    await send(JSON.stringify({ topic, timestamp: logNs.toString(), data: Buffer.from(data).toString("hex") }));
  }
  py.stdin.end();
  await done;
}

await (opt.format === "mcap" ? writeMcap() : writeSqlite());
