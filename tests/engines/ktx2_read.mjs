// Reads a KTX2 file with ktx-parse (the parser three.js vendors, three/examples/jsm/libs) and
// prints its header, key/value data, DFD samples and every level's bytes (base64) as JSON.
// usage: node ktx2_read.mjs FILE.ktx2
import fs from "node:fs";
import { read } from "three/examples/jsm/libs/ktx-parse.module.js";

const c = read(new Uint8Array(fs.readFileSync(process.argv[2])));
const kv = {};
for (const [k, v] of Object.entries(c.keyValue)) kv[k] = typeof v === "string" ? v : new TextDecoder().decode(v).replace(/\0$/, "");
const dfd = c.dataFormatDescriptor[0];
process.stdout.write(JSON.stringify({
  vkFormat: c.vkFormat, typeSize: c.typeSize, pixelWidth: c.pixelWidth, pixelHeight: c.pixelHeight,
  pixelDepth: c.pixelDepth, layerCount: c.layerCount, faceCount: c.faceCount, levelCount: c.levelCount, supercompressionScheme: c.supercompressionScheme,
  colorModel: dfd.colorModel, transferFunction: dfd.transferFunction, colorPrimaries: dfd.colorPrimaries,
  bytesPlane0: dfd.bytesPlane[0],
  samples: dfd.samples.map((s) => ({ bitOffset: s.bitOffset, bitLength: s.bitLength, channelType: s.channelType })),
  keyValue: kv,
  levels: c.levels.map((l) => Buffer.from(l.levelData.buffer, l.levelData.byteOffset, l.levelData.byteLength).toString("base64")),
}) + "\n");
