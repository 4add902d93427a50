// Filament page (tests/engines/harness.mjs): loads shbake's --to filament IBL with the snippet of
// docs/EXPORTS.md (between the markers, verbatim; tests/system/test_engine_render.py checks) and renders
// a unit sphere (a glTF through gltfio's ubershaders: Filament's web build draws glTF materials)
// into a half-float drawing buffer (WebGL2 drawingBufferStorage RGBA16F), post-processing off (no
// tone mapping, no output transform) and exposure 1, then once more with an unlit sphere whose
// vertex colours are 0.5 + 0.5 n (the normal pass). Filament's world is shbake's (right-handed,
// +Y up): views are used as they are. Filament is a classic script: it defines `Filament`.
import { encodeRows } from "./common.mjs";
// BEGIN snippet Filament
// shbake's Filament IBL (STEM_ibl.ktx, cmgen's format, the SH in its "sh" metadata). Filament
// 1.53's createIblFromKtx1 reads that SH into ibl.shfloats but never gives it to the light
// (the diffuse would come from the reflections), so the light is built here with it.
function loadShbakeIbl(engine, iblKtx) {
  const sh = new Filament.Ktx1Bundle(Filament.Buffer(iblKtx)).getMetadata("sh");
  return Filament.IndirectLight.Builder()
    .reflections(engine.createTextureFromKtx1(iblKtx))
    .irradianceSh(3, Float32Array.from(sh.trim().split(/\s+/), parseFloat))
    .intensity(1.0) // shbake's radiance as baked (Filament's default is 30000 lux)
    .build(engine);
}
// END snippet Filament

const ready = new Promise((resolve) => Filament.init([], resolve));

async function bytes(url) {
  return new Uint8Array(await (await fetch(url)).arrayBuffer());
}

async function loadAsset(loader, data) {
  const asset = loader.createAsset(data);
  await new Promise((resolve) => asset.loadResources(resolve));
  return asset;
}

/** Half floats (Uint16Array) -> Float32Array. */
function halfToFloat(h) {
  const out = new Float32Array(h.length);
  for (let i = 0; i < h.length; i++) {
    const e = (h[i] >> 10) & 31, m = h[i] & 1023, s = h[i] >> 15 ? -1 : 1;
    out[i] = s * (e === 0 ? m * 2 ** -24 : e === 31 ? (m ? NaN : Infinity) : (1 + m / 1024) * 2 ** (e - 15));
  }
  return out;
}

// Every (material, view) image is a tile of one drawing buffer, drawn in a single frame (Filament
// paces frames with GPU fences: a page cannot render frame after frame on demand); tile row 0 is
// the normal pass, row 1 + i material i, column k view k.
window.shbakeRender = async function (p) {
  await ready;
  const rows = 1 + p.materials.length, cols = p.views.length, n = p.size;
  const canvas = document.getElementById("c");
  canvas.width = cols * n;
  canvas.height = rows * n;
  const gl = canvas.getContext("webgl2", { antialias: false, depth: true, alpha: true });
  gl.getExtension("EXT_color_buffer_float");
  gl.drawingBufferStorage(gl.RGBA16F, canvas.width, canvas.height);
  const engine = Filament.Engine.create(canvas);
  const renderer = engine.createRenderer();
  const swapChain = engine.createSwapChain();
  renderer.setClearOptions({ clearColor: [0, 0, 0, 0], clear: true });
  const light = p.ibl ? loadShbakeIbl(engine, await bytes(p.ibl)) : null;
  const loader = engine.createAssetLoader();
  const rm = engine.getRenderableManager();
  const spheres = {};
  for (const kind of ["lit", "diffuse", "normal"]) spheres[kind] = await bytes(p.spheres[kind]);
  const rowsSpec = [{ kind: "normal" }, ...p.materials];
  const views = [];
  for (let row = 0; row < rows; row++) {
    const m = rowsSpec[row];
    const asset = await loadAsset(loader, spheres[m.kind === "normal" ? "normal" : m.kind === "lambert" ? "diffuse" : "lit"]);
    if (row > 0) {
      const mi = rm.getMaterialInstanceAt(rm.getInstance(asset.getRenderableEntities()[0]), 0);
      mi.setFloat4Parameter("baseColorFactor", [...m.color, 1.0]);
      mi.setFloatParameter("metallicFactor", m.metalness);
      mi.setFloatParameter("roughnessFactor", m.roughness);
    }
    const scene = engine.createScene();
    scene.addEntities(asset.getEntities());
    if (light) scene.setIndirectLight(light);
    for (let col = 0; col < cols; col++) {
      const v = p.views[col];
      const camera = engine.createCamera(Filament.EntityManager.get().create());
      camera.setProjectionFov(p.fov_deg, 1.0, 0.1, 100.0, Filament.Camera$Fov.VERTICAL);
      camera.setExposureDirect(1.0);
      camera.lookAt(v.eye, v.target, v.up);
      const view = engine.createView();
      view.setCamera(camera);
      view.setScene(scene);
      view.setPostProcessingEnabled(false);
      view.setViewport([col * n, (rows - 1 - row) * n, n, n]);
      views.push(view);
    }
  }
  for (let tries = 0; !renderer.beginFrame(swapChain); tries++) {
    if (tries > 200) throw new Error("Filament skipped every frame");
    await new Promise((r) => requestAnimationFrame(r));
  }
  for (const view of views) renderer.renderView(view);
  renderer.endFrame();
  engine.execute();
  const bound = gl.getParameter(gl.READ_FRAMEBUFFER_BINDING);
  gl.bindFramebuffer(gl.READ_FRAMEBUFFER, null);
  const half = new Uint16Array(canvas.width * canvas.height * 4);
  gl.readPixels(0, 0, canvas.width, canvas.height, gl.RGBA, gl.HALF_FLOAT, half);
  gl.bindFramebuffer(gl.READ_FRAMEBUFFER, bound);
  const all = halfToFloat(half);
  const tile = (row, col) => {
    const t = new Float32Array(n * n * 4);
    const y0 = (rows - 1 - row) * n; // readPixels rows run bottom first
    for (let y = 0; y < n; y++) {
      const src = ((y0 + y) * canvas.width + col * n) * 4;
      t.set(all.subarray(src, src + n * 4), y * n * 4);
    }
    return t;
  };
  const out = { normal: [], radiance: {} };
  for (let col = 0; col < cols; col++) {
    const t = tile(0, col);
    for (let i = 0; i < t.length; i += 4) for (let c = 0; c < 3; c++) t[i + c] = 2 * t[i + c] - 1;
    out.normal.push(encodeRows(t, n, n));
  }
  p.materials.forEach((m, i) => {
    out.radiance[m.name] = p.views.map((_, col) => encodeRows(tile(1 + i, col), n, n));
  });
  return out;
};
