// Loads a shbake .gltf with Babylon.js's own glTF loader (NullEngine, node) and prints,
// as JSON, the irradiance Babylon shades a Lambert surface with at glTF normals n:
//   E_babylon(n) = pi * (environmentIrradiance(n) + sum over directional lights of
//                        diffuseTerm(1/pi) * intensity * color * max(0, N.L) * pi / pi)
// Every number comes from the loaded scene: the scene's environment texture (its
// sphericalPolynomial.preScaledHarmonics, level, reflection matrix, invertZ, coordinatesMode),
// the glTF root node's world matrix, the loaded DirectionalLight. The shader steps
// (pbrBlockReflection.fx: irradianceVector = reflectionMatrix * normalW, OPPOSITEZ / INVERTCUBICMAP
// flips, computeEnvironmentIrradiance, *= vReflectionInfos.x) are evaluated here on those numbers;
// the script checks that the installed shader source still contains the formula it evaluates.
// usage: node babylon_irradiance.mjs DIRS.json rh|lh FILE.gltf...   (DIRS: [[x,y,z], ...] in glTF
// frame; rh: a right-handed scene): a JSON list, one entry per file, each loaded in a scene of its
// own (one node start for several files: ~0.5 s of CPU each saved).
import fs from "node:fs";
import path from "node:path";
import { NullEngine } from "@babylonjs/core/Engines/nullEngine.js";
import { Scene } from "@babylonjs/core/scene.js";
import { Vector3 } from "@babylonjs/core/Maths/math.vector.js";
import { LoadAssetContainerAsync, AppendSceneAsync } from "@babylonjs/core/Loading/sceneLoader.js";
import { InternalTexture } from "@babylonjs/core/Materials/Textures/internalTexture.js";
import { DirectionalLight } from "@babylonjs/core/Lights/directionalLight.js";
import "@babylonjs/loaders/glTF/2.0/index.js";
import "@babylonjs/core/Materials/Textures/baseTexture.polynomial.js"; // registers BaseTexture.sphericalPolynomial (as the full bundle does)
import { harmonicsFunctions } from "@babylonjs/core/Shaders/ShadersInclude/harmonicsFunctions.js";
import { pbrBlockReflection } from "@babylonjs/core/Shaders/ShadersInclude/pbrBlockReflection.js";

// node has no HTMLImageElement: a stand-in that "loads" at once (the NullEngine uploads nothing).
globalThis.Image = class {
  set src(v) { this._src = v; setTimeout(() => this.onload && this.onload(), 0); }
  get src() { return this._src; }
  get width() { return 1; }
  get height() { return 1; }
};

const [dirsFile, handedness, ...files] = process.argv.slice(2);
if (!["rh", "lh"].includes(handedness) || !files.length) throw new Error("usage: DIRS.json rh|lh FILE.gltf...");
const dirs = JSON.parse(fs.readFileSync(dirsFile, "utf8"));

const shaderH = harmonicsFunctions.shader;
const shaderR = pbrBlockReflection.shader;
for (const needle of [
  "vSphericalL00\n+ vSphericalL1_1*(normal.y)\n+ vSphericalL10*(normal.z)\n+ vSphericalL11*(normal.x)\n+ vSphericalL2_2*(normal.y*normal.x)\n+ vSphericalL2_1*(normal.y*normal.z)\n+ vSphericalL20*((3.0*normal.z*normal.z)-1.0)\n+ vSphericalL21*(normal.z*normal.x)\n+ vSphericalL22*(normal.x*normal.x-(normal.y*normal.y))",
]) if (!shaderH.includes(needle)) throw new Error("harmonicsFunctions changed: " + needle);
for (const needle of [
  "vec3 irradianceVector=vec3(reflectionMatrix*vec4(normalW,0)).xyz;",
  "#ifdef REFLECTIONMAP_OPPOSITEZ\nirradianceVector.z*=-1.0;",
  "#ifdef INVERTCUBICMAP\nirradianceVector.y*=-1.0;",
  "environmentIrradiance=computeEnvironmentIrradiance(irradianceVector);",
  "environmentIrradiance*=vReflectionColor.rgb*vReflectionInfos.x;",
]) if (!shaderR.includes(needle)) throw new Error("pbrBlockReflection changed: " + needle);

async function irradianceOf(file) {
  const doc = JSON.parse(fs.readFileSync(file, "utf8"));
  // external files -> data URIs (node's fetch has no file://); the loader then decodes them itself
  for (const img of doc.images || []) {
    if (img.uri && !img.uri.startsWith("data:")) {
      const bytes = fs.readFileSync(path.join(path.dirname(file), decodeURIComponent(img.uri)));
      img.uri = `data:${img.mimeType};base64,` + bytes.toString("base64");
    }
  }
  const engine = new NullEngine();
  // NullEngine has no GL context for raw cube textures: allocate them without GPU storage.
  // (Only the upload is stubbed; the loader, SH and texture objects are Babylon's own.)
  engine.createRawCubeTexture = function (data, size, format, type, generateMipMaps, invertY, samplingMode) {
    const t = new InternalTexture(this, 9 /* InternalTextureSource.CubeRaw */);
    t.isCube = true; t.format = format; t.type = type; t.generateMipMaps = generateMipMaps;
    t.width = t.height = t.baseWidth = t.baseHeight = size; t.invertY = invertY; t.samplingMode = samplingMode;
    t.isReady = true;
    return t;
  };
  engine._uploadImageToTexture = function () {};
  const scene = new Scene(engine);
  if (handedness === "rh") scene.useRightHandedSystem = true;
  await AppendSceneAsync("data:" + JSON.stringify(doc), scene, { pluginExtension: ".gltf" });
  const tex = scene.environmentTexture;
  if (!tex) throw new Error("no environment texture after loading");
  await new Promise((r) => { const t = () => (tex.isReady() ? r() : setTimeout(t, 5)); t(); });
  const h = tex.sphericalPolynomial.preScaledHarmonics; // what BindIBLParameters uploads
  const refl = tex.getReflectionTextureMatrix();
  // defines as materialHelper.functions PrepareDefinesForIBL / BindIBLSamplers set them
  const OPPOSITEZ = tex.isCube && scene.useRightHandedSystem ? !tex.invertZ : tex.invertZ;
  const INVERTCUBIC = tex.coordinatesMode === 6;
  const level = tex.level * scene.iblIntensity; // vReflectionInfos.x
  const root = scene.getMeshByName("__root__") || scene.getTransformNodeByName("__root__");
  const world = root.computeWorldMatrix(true);
  const lights = scene.lights.filter((l) => l instanceof DirectionalLight).map((l) => {
    l.computeWorldMatrix(true);
    const dir = l.getShadowDirection ? l.direction : l.direction;
    // a glTF light node: Babylon DirectionalLight.direction in its parent's (root's) frame; world direction:
    const wd = Vector3.TransformNormal(l.direction, l.parent ? l.parent.computeWorldMatrix(true) : world).normalize();
    return { wd, color: l.diffuse, intensity: l.intensity };
  });
  const out = [];
  for (const d of dirs) {
    const nW = Vector3.TransformNormal(new Vector3(d[0], d[1], d[2]), world).normalize(); // normalW
    const v = Vector3.TransformNormal(nW, refl);
    if (OPPOSITEZ) v.z *= -1;
    if (INVERTCUBIC) v.y *= -1;
    const e = [0, 0, 0];
    const ch = ["x", "y", "z"];
    for (let c = 0; c < 3; c++) {
      const k = ch[c];
      let val = h.l00[k] + h.l1_1[k] * v.y + h.l10[k] * v.z + h.l11[k] * v.x + h.l2_2[k] * (v.y * v.x)
        + h.l2_1[k] * (v.y * v.z) + h.l20[k] * (3 * v.z * v.z - 1) + h.l21[k] * (v.z * v.x)
        + h.l22[k] * (v.x * v.x - v.y * v.y);
      val *= level;
      // pbrDirectLightingFunctions: diffuse = (1/pi) * NdotL * lightColor, lightColor = diffuse * intensity
      for (const L of lights) {
        const ndl = Math.max(0, -(nW.x * L.wd.x + nW.y * L.wd.y + nW.z * L.wd.z));
        val += (1 / Math.PI) * ndl * L.color[["r", "g", "b"][c]] * L.intensity;
      }
      e[c] = Math.PI * val; // irradiance = pi * Lambert radiance at albedo 1
    }
    out.push(e);
  }
  engine.dispose();
  return {
    irradiance: out,
    level, opposite_z: OPPOSITEZ, invert_cubic: INVERTCUBIC, right_handed: scene.useRightHandedSystem,
    root_world: Array.from(world.m), lights: lights.length,
  };
}

const results = [];
for (const file of files) results.push(await irradianceOf(file));
process.stdout.write(JSON.stringify(results) + "\n");
