// Reads a ROS 2 MCAP file the way a node user of the MCAP libraries would:
// @mcap/core's McapStreamReader (CRCs checked, zstd and lz4 chunks) and
// @foxglove/rosmsg2-serialization's MessageReader on each channel's ros2msg
// schema, deserialising every message of the topics sweepscan imports. It
// is the reference side of scripts/ros-import-bench.sh (ROS 2) and a check
// that session_to_ros2.mjs's files are read by others.
//
// Prints JSON: messages per topic, and how many messages went back in log time.
// usage: node read_mcap.mjs FILE.mcap
import fs from "node:fs";
import { McapStreamReader } from "@mcap/core";
import { parse } from "@foxglove/rosmsg";
import { MessageReader } from "@foxglove/rosmsg2-serialization";
import zstd from "@foxglove/wasm-zstd";
import lz4 from "lz4js";

const file = process.argv[2];
if (!file) throw new Error("usage: node read_mcap.mjs FILE.mcap");
const TOPICS = new Set(["/scan", "/odom", "/imu/data", "/tf", "/tf_static"]);

await zstd.isLoaded;
const reader = new McapStreamReader({
  validateCrcs: true,
  decompressHandlers: {
    zstd: (data, size) => zstd.decompress(data, Number(size)),
    lz4: (data, size) => lz4.decompress(data, Number(size)),
  },
});
const schemas = new Map(), channels = new Map(), counts = {};
let backwards = 0, lastLog = 0n;
// The file in pieces, as it would be streamed: memory stays one chunk.
for await (const piece of fs.createReadStream(file, { highWaterMark: 1 << 20 })) {
  reader.append(piece);
  for (let r; (r = reader.nextRecord());) {
    if (r.type === "Schema") {
      schemas.set(r.id, new MessageReader(parse(new TextDecoder().decode(r.data), { ros2: true })));
    } else if (r.type === "Channel") {
      channels.set(r.id, { topic: r.topic, reader: schemas.get(r.schemaId) });
    } else if (r.type === "Message") {
      const c = channels.get(r.channelId);
      if (TOPICS.has(c.topic)) c.reader.readMessage(r.data);
      counts[c.topic] = (counts[c.topic] ?? 0) + 1;
      if (r.logTime < lastLog) backwards++;
      lastLog = r.logTime;
    }
  }
}
if (!reader.done()) throw new Error(`${file}: ends before the MCAP footer`);
console.log(JSON.stringify({ file, messages: counts, log_time_backwards: backwards }));
