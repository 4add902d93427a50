// Loads a shbake three.js export with three's own ObjectLoader and prints, as JSON, the
// irradiance three shades a Lambert surface with at normals n: for every LightProbe
// probe.sh.getIrradianceAt(n) * probe.intensity (LightProbe / SphericalHarmonics3 code), plus
// for every DirectionalLight color * intensity * max(0, n . l), l = normalize(position - target)
// (lights_pars_begin.glsl getDirectionalLightInfo + RE_Direct: irradiance = dotNL * directLight.color).
// and every LightProbe's position (Object3D.position, decomposed from its matrix).
// usage: node three_irradiance.mjs FILE.json DIRS.json
import fs from "node:fs";
import { ObjectLoader, Vector3, LightProbe, DirectionalLight } from "three";

const [file, dirsFile] = process.argv.slice(2);
const scene = new ObjectLoader().parse(JSON.parse(fs.readFileSync(file, "utf8")));
scene.updateMatrixWorld(true);
const dirs = JSON.parse(fs.readFileSync(dirsFile, "utf8"));
const probes = [], suns = [];
scene.traverse((o) => {
  if (o instanceof LightProbe) probes.push(o);
  if (o instanceof DirectionalLight) {
    o.target.updateMatrixWorld(true);
    const p = new Vector3().setFromMatrixPosition(o.matrixWorld);
    const t = new Vector3().setFromMatrixPosition(o.target.matrixWorld);
    suns.push({ l: p.sub(t).normalize(), c: o.color.clone().multiplyScalar(o.intensity) });
  }
});
const out = dirs.map((d) => {
  const n = new Vector3(d[0], d[1], d[2]);
  const e = new Vector3();
  for (const p of probes) e.add(p.sh.getIrradianceAt(n, new Vector3()).multiplyScalar(p.intensity));
  for (const s of suns) {
    const ndl = Math.max(0, n.dot(s.l));
    e.x += ndl * s.c.r; e.y += ndl * s.c.g; e.z += ndl * s.c.b;
  }
  return [e.x, e.y, e.z];
});
const positions = probes.map((p) => p.position.toArray());
process.stdout.write(
  JSON.stringify({ irradiance: out, probes: probes.length, lights: suns.length, positions }) + "\n",
);
