// Runs the Khronos glTF validator (npm gltf-validator) on a .gltf and prints its report's
// issue counts and messages as JSON. usage: node validate_gltf.mjs FILE.gltf
import fs from "node:fs";
import path from "node:path";
import validator from "gltf-validator";

const file = process.argv[2];
const report = await validator.validateBytes(new Uint8Array(fs.readFileSync(file)), {
  uri: path.basename(file),
  externalResourceFunction: (uri) =>
    new Promise((resolve, reject) => {
      try { resolve(new Uint8Array(fs.readFileSync(path.join(path.dirname(file), decodeURIComponent(uri))))); }
      catch (e) { reject(e.toString()); }
    }),
});
const i = report.issues;
process.stdout.write(JSON.stringify({
  numErrors: i.numErrors, numWarnings: i.numWarnings, numInfos: i.numInfos,
  messages: i.messages.map((m) => `${m.severity} ${m.code} ${m.pointer || ""}: ${m.message}`),
}) + "\n");
