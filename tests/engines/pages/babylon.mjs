// Babylon.js page (tests/engines/harness.mjs): loads shbake's --to babylon exports with the snippets of
// docs/EXPORTS.md (between the markers, verbatim; tests/system/test_engine_render.py checks) and renders a
// unit sphere into a float render target (image processing off: no tone mapping, no output gamma),
// then once more with a material writing the interpolated world normal. Babylon's scene is
// left-handed: as its glTF loader does for glTF content (root node mirrored in x), shbake's world
// point (x, y, z) is Babylon's (-x, y, z); the page mirrors the cameras in and the normals out.
import * as BABYLON from "@babylonjs/core";
import { encodeRows } from "./common.mjs";
// BEGIN snippet Babylon.js
import { AppendSceneAsync, CubeTexture } from "@babylonjs/core";
import "@babylonjs/loaders/glTF";

// shbake's .env (--to babylon -o sky.env): Babylon's own prefiltered RGBD cube + SH.
async function loadShbakeEnv(scene, url) {
  const env = CubeTexture.CreateFromPrefilteredData(url, scene);
  await new Promise((resolve) => env.onLoadObservable.addOnce(resolve));
  scene.environmentTexture = env;
}

// shbake's glTF (--to gltf|babylon -o sky.gltf): EXT_lights_image_based (+ KHR_lights_punctual sun).
async function loadShbakeGltf(scene, url) {
  await AppendSceneAsync(url, scene);
  scene.environmentTexture.gammaSpace = false; // the RGBD images hold linear radiance
}
// END snippet Babylon.js

const mirror = (v) => new BABYLON.Vector3(-v[0], v[1], v[2]);

function material(scene, m) {
  const mat = new BABYLON.PBRMaterial(m.name, scene);
  mat.albedoColor = new BABYLON.Color3(...m.color);
  mat.metallic = m.metalness;
  mat.roughness = m.roughness;
  if (m.kind === "lambert") mat.metallicF0Factor = 0; // no specular lobe: the diffuse alone
  return mat;
}

window.shbakeRender = async function (p) {
  const canvas = document.getElementById("c");
  const engine = new BABYLON.Engine(canvas, false, { preserveDrawingBuffer: true });
  const scene = new BABYLON.Scene(engine);
  // image processing "by post-process" with no post-process attached: linear HDR out, unclamped
  scene.imageProcessingConfiguration.applyByPostProcess = true;
  scene.imageProcessingConfiguration.skipFinalColorClamp = true;
  scene.clearColor = new BABYLON.Color4(0, 0, 0, 0);
  if (p.env) await loadShbakeEnv(scene, p.env);
  if (p.gltf) await loadShbakeGltf(scene, p.gltf);
  // fault tests only: Babylon's default gammaSpace back on the environment (radiance decoded twice)
  if (p.gammaSpace !== undefined) scene.environmentTexture.gammaSpace = p.gammaSpace;
  const camera = new BABYLON.TargetCamera("camera", new BABYLON.Vector3(0, 0, 4), scene);
  camera.fov = (p.fov_deg * Math.PI) / 180;
  camera.minZ = 0.1;
  camera.maxZ = 100;
  scene.activeCamera = camera;
  const sphere = BABYLON.CreateSphere("sphere", { diameter: 2, segments: 128 }, scene);
  const normalMaterial = new BABYLON.ShaderMaterial("normal", scene, {
    vertexSource: "precision highp float; attribute vec3 position; attribute vec3 normal; "
      + "uniform mat4 world; uniform mat4 worldViewProjection; varying vec3 vN; "
      + "void main() { vN = mat3(world) * normal; gl_Position = worldViewProjection * vec4(position, 1.0); }",
    fragmentSource: "precision highp float; varying vec3 vN; "
      + "void main() { vec3 n = normalize(vN); gl_FragColor = vec4(-n.x, n.y, n.z, 1.0); }",
  }, { attributes: ["position", "normal"], uniforms: ["world", "worldViewProjection"] });
  const target = new BABYLON.RenderTargetTexture("target", p.size, scene, {
    generateMipMaps: false, type: BABYLON.Constants.TEXTURETYPE_FLOAT,
  });
  target.renderList = [sphere];
  target.activeCamera = camera;
  target.clearColor = new BABYLON.Color4(0, 0, 0, 0);
  const pass = async (mat, view) => {
    sphere.material = mat;
    camera.position = mirror(view.eye);
    camera.upVector = mirror(view.up);
    camera.setTarget(mirror(view.target));
    await scene.whenReadyAsync();
    await mat.forceCompilationAsync(sphere);
    target.render();
    const pixels = await target.readPixels();
    return encodeRows(new Float32Array(pixels.buffer), p.size, p.size);
  };
  const out = { normal: [], radiance: {} };
  for (const v of p.views) out.normal.push(await pass(normalMaterial, v));
  for (const m of p.materials) {
    const mat = material(scene, m);
    out.radiance[m.name] = [];
    for (const v of p.views) out.radiance[m.name].push(await pass(mat, v));
  }
  engine.dispose();
  return out;
};
