// three.js page (tests/engines/harness.mjs): loads shbake's --to threejs export with the snippet of
// docs/EXPORTS.md (between the markers, verbatim; tests/system/test_engine_render.py checks) and renders
// a unit sphere into a float render target, tone mapping and output encoding off, then once more
// with a material writing the interpolated world normal.
import * as THREE from "three";
import { encodeRows } from "./common.mjs";
// BEGIN snippet three.js
import { CompressedCubeTexture, LinearFilter, LinearMipmapLinearFilter } from "three";
import { KTX2Loader } from "three/addons/loaders/KTX2Loader.js";

// shbake's prefiltered GGX cube (STEM_pmrem.ktx2) as the PMREM texture three samples as is.
async function loadShbakePMREM(renderer, url) {
  const flat = await new KTX2Loader().detectSupport(renderer).loadAsync(url);
  const faces = [0, 1, 2, 3, 4, 5].map((f) => ({
    width: flat.image.width,
    height: flat.image.height,
    mipmaps: flat.mipmaps.map((m) => ({
      width: m.width,
      height: m.height,
      data: m.data.subarray((f * m.data.length) / 6, ((f + 1) * m.data.length) / 6),
    })),
  }));
  const env = new CompressedCubeTexture(faces, flat.format, flat.type);
  env.isPMREMTexture = true; // already prefiltered: no PMREMGenerator pass
  env.minFilter = LinearMipmapLinearFilter;
  env.magFilter = LinearFilter;
  env.generateMipmaps = false;
  env.needsUpdate = true;
  return env;
}
// END snippet three.js

// The normal pass also writes, as 1 + alpha, the geometry roughness three adds to every
// material's roughness: lights_physical_fragment's getGeometryRoughness of the view-space
// normal (normal_vertex, normal_fragment_begin), with this GPU's own derivatives.
const NORMAL_MATERIAL = new THREE.ShaderMaterial({
  vertexShader: "out vec3 vN; out vec3 vV; void main() { vN = mat3(modelMatrix) * normal; "
    + "vV = normalize(normalMatrix * normal); "
    + "gl_Position = projectionMatrix * modelViewMatrix * vec4(position, 1.0); }",
  fragmentShader: "in vec3 vN; in vec3 vV; void main() { vec3 v = normalize(vV); "
    + "vec3 dxy = max(abs(dFdx(v)), abs(dFdy(v))); "
    + "gl_FragColor = vec4(normalize(vN), 1.0 + max(max(dxy.x, dxy.y), dxy.z)); }",
});

function material(m) {
  const color = new THREE.Color(...m.color);
  if (m.kind === "lambert") return new THREE.MeshLambertMaterial({ color });
  return new THREE.MeshStandardMaterial({ color, metalness: m.metalness, roughness: m.roughness });
}

window.shbakeRender = async function (p) {
  const canvas = document.getElementById("c");
  const renderer = new THREE.WebGLRenderer({ canvas, antialias: false });
  renderer.toneMapping = THREE.NoToneMapping;
  renderer.outputColorSpace = THREE.LinearSRGBColorSpace;
  const scene = new THREE.Scene();
  if (p.probe) scene.add(...(await new THREE.ObjectLoader().loadAsync(p.probe)).children);
  if (p.pmrem) scene.environment = await loadShbakePMREM(renderer, p.pmrem);
  const target = new THREE.WebGLRenderTarget(p.size, p.size, { type: THREE.FloatType });
  const sphere = new THREE.Mesh(new THREE.SphereGeometry(1, 256, 128), NORMAL_MATERIAL);
  scene.add(sphere);
  const camera = new THREE.PerspectiveCamera(p.fov_deg, 1, 0.1, 100);
  const pixels = new Float32Array(p.size * p.size * 4);
  const pass = (mat, view) => {
    sphere.material = mat;
    camera.position.set(...view.eye);
    camera.up.set(...view.up);
    camera.lookAt(...view.target);
    renderer.setRenderTarget(target);
    renderer.setClearColor(0x000000, 0);
    renderer.clear();
    renderer.render(scene, camera);
    renderer.readRenderTargetPixels(target, 0, 0, p.size, p.size, pixels);
    return encodeRows(pixels, p.size, p.size);
  };
  const out = { normal: p.views.map((v) => pass(NORMAL_MATERIAL, v)), radiance: {} };
  for (const m of p.materials) {
    const mat = material(m);
    out.radiance[m.name] = p.views.map((v) => pass(mat, v));
  }
  renderer.dispose();
  return out;
};
