// Reads a LAS 1.4 file with two independent npm readers, as the check of
// sweepscan's LAS export (tests/core/cloud/las_writer_test.cc):
//
// loaders.gl: @loaders.gl/core's parse() with @loaders.gl/las's LAZRsLoader,
//   the header (version, point format, record length, count, scale, offset,
//   min/max) and the positions it decodes (X * scale + offset, doubles).
//   LAZRsLoader is the loader that reads LAS 1.4: the package's default
//   LASLoader (laz-perf) takes the legacy 32-bit point count, which point
//   formats 6-10 must set to 0, and so finds no points. loaders.gl exposes
//   neither GPS time nor extra bytes nor VLRs, hence:
// copc: copc.js's Las.Header / Las.Vlr / Las.ExtraBytes / Las.View (Hobu's
//   LAS 1.4 utilities): the global encoding, creation date, VLRs (the WKT),
//   the Extra Bytes descriptors, and per point GPS time, return numbers,
//   classification, user data, point source ID and the extra bytes.
//
// Prints JSON: both readers' header fields; `points`: for the first N, the
// last N and every STRIDE-th point, loaders.gl's position and copc's fields.
// usage: node read_las.mjs FILE.las [N=20] [STRIDE=1000]
import fs from "node:fs";
import { parse } from "@loaders.gl/core";
import { LAZRsLoader } from "@loaders.gl/las";
import { Las } from "copc";

const [file, nArg, strideArg] = process.argv.slice(2);
if (!file) throw new Error("usage: node read_las.mjs FILE.las [N] [STRIDE]");
const N = Number(nArg ?? 20), STRIDE = Number(strideArg ?? 1000);

// LAZRsLoader initialises its WebAssembly (laz-rs, used for LAZ only) by
// fetch()ing it from a file: URL, which node's fetch does not do: hand it the
// module's bytes first (the loader then finds it initialised).
const lasEntry = import.meta.resolve("@loaders.gl/las");
const lazRs = await import(new URL("./libs/laz-rs-wasm/laz_rs_wasm.js", lasEntry));
await lazRs.default({ module_or_path: fs.readFileSync(new URL("./libs/laz-rs-wasm/laz_rs_wasm_bg.wasm", lasEntry)) });

const bytes = fs.readFileSync(file);
const buffer = bytes.buffer.slice(bytes.byteOffset, bytes.byteOffset + bytes.byteLength);
const mesh = await parse(buffer, LAZRsLoader, { worker: false, las: { fp64: true, skip: 1 } });
const h = mesh.loaderData;
const pos = mesh.attributes.POSITION.value;
const count = mesh.header.vertexCount;

const header = Las.Header.parse(bytes);
const vlrs = await Las.Vlr.walk(file, header);
const content = (v) => bytes.subarray(v.contentOffset, v.contentOffset + v.contentLength);
const wktVlr = Las.Vlr.find(vlrs, "LASF_Projection", 2112);
const ebVlr = Las.Vlr.find(vlrs, "LASF_Spec", 4);
const extraBytes = ebVlr ? Las.ExtraBytes.parse(content(ebVlr)) : [];
const pointBytes = bytes.subarray(header.pointDataOffset,
  header.pointDataOffset + header.pointCount * header.pointDataRecordLength);
const view = Las.View.create(pointBytes, header, extraBytes);
const fields = ["X", "Y", "Z", "GpsTime", "Intensity", "ReturnNumber", "NumberOfReturns", "Classification",
  "Synthetic", "KeyPoint", "Withheld", "Overlap", "ScannerChannel", "ScanDirectionFlag", "EdgeOfFlightLine",
  "UserData", "ScanAngle", "PointSourceId", ...extraBytes.map((e) => e.name)];
const getters = Object.fromEntries(fields.map((f) => [f, view.getter(f)]));

const pick = [];
for (let i = 0; i < Math.min(N, count); i++) pick.push(i);
for (let i = STRIDE; i < count - N; i += STRIDE) if (i >= N) pick.push(i);
for (let i = Math.max(N, count - N); i < count; i++) pick.push(i);
const points = pick.map((i) => ({
  index: i,
  position: [pos[3 * i], pos[3 * i + 1], pos[3 * i + 2]],
  copc: Object.fromEntries(fields.map((f) => [f, getters[f](i)])),
}));

console.log(JSON.stringify({
  file,
  loaders_gl: {
    version: h.versionAsString,
    point_format: h.pointsFormatId,
    record_length: h.pointsStructSize,
    point_data_offset: h.pointsOffset,
    count: h.pointsCount,
    decoded: count,
    scale: h.scale,
    offset: h.offset,
    mins: h.mins,
    maxs: h.maxs,
    bounding_box: mesh.header.boundingBox,
    intensity_max: mesh.attributes.intensity.value.reduce((a, b) => Math.max(a, b), 0),
  },
  copc: {
    header,
    vlrs: vlrs.map(({ userId, recordId, contentLength, description }) => ({ userId, recordId, contentLength, description })),
    wkt: wktVlr ? new TextDecoder().decode(content(wktVlr)) : null,
    extra_bytes: extraBytes,
    view_points: view.pointCount,
  },
  points,
}));
