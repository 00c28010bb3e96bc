// Rewrites an MCAP file with @mcap/core's own reader and writer (never
// sweepscan's code) so that its chunks are out of log-time order, as the
// MCAP spec allows: the messages in blocks of N, each pair of blocks
// swapped (1 0 3 2 5 4 ...), zstd chunks of 64 kB. Chunks then go back in
// time and overlap where a block ends inside a chunk. Schemas and channels
// are registered first, so every channel precedes its messages.
//
// usage (from tests/tools, whose node_modules it imports):
//   node --input-type=module - IN OUT N < mcap_out_of_order.mjs
import fs from "node:fs";
import { McapStreamReader, McapWriter } from "@mcap/core";
import zstd from "@foxglove/wasm-zstd";

await zstd.isLoaded;
const [input, output, blockText] = process.argv.slice(2);
const block = Number(blockText);
const reader = new McapStreamReader({
  decompressHandlers: { zstd: (data, size) => zstd.decompress(data, Number(size)) } });
reader.append(fs.readFileSync(input));
const schemas = [], channels = [], messages = [];
for (let rec; (rec = reader.nextRecord());) {
  if (rec.type === "Schema") schemas.push(rec);
  if (rec.type === "Channel") channels.push(rec);
  if (rec.type === "Message") messages.push(rec);
}
if (!reader.done()) throw new Error(input + ": not read to its end");

const order = [];
for (let b = 0; b * block < messages.length; b += 2) {
  const first = messages.slice(b * block, (b + 1) * block);
  const second = messages.slice((b + 1) * block, (b + 2) * block);
  order.push(...second, ...first);
}

class FileWritable {
  constructor(file) { this.fd = fs.openSync(file, "w"); this.pos = 0n; }
  position() { return this.pos; }
  async write(buf) {
    for (let off = 0; off < buf.byteLength;) off += fs.writeSync(this.fd, buf, off);
    this.pos += BigInt(buf.byteLength);
  }
  close() { fs.closeSync(this.fd); }
}
const file = new FileWritable(output);
const writer = new McapWriter({
  writable: file, chunkSize: 64 * 1024,
  compressChunk: (data) => ({ compression: "zstd", compressedData: zstd.compress(data, 3) }) });
await writer.start({ profile: "ros2", library: "mcap_out_of_order.mjs (@mcap/core)" });
const schemaIds = new Map(), channelIds = new Map();
for (const s of schemas) {
  schemaIds.set(s.id, await writer.registerSchema({ name: s.name, encoding: s.encoding, data: s.data }));
}
for (const c of channels) {
  channelIds.set(c.id, await writer.registerChannel({
    topic: c.topic, schemaId: schemaIds.get(c.schemaId), messageEncoding: c.messageEncoding,
    metadata: c.metadata }));
}
for (const m of order) {
  await writer.addMessage({ channelId: channelIds.get(m.channelId), sequence: m.sequence,
                            logTime: m.logTime, publishTime: m.publishTime, data: m.data });
}
await writer.end();
file.close();
console.log(`${output}: ${order.length} messages in blocks of ${block}, pairs swapped`);
