// The viewer of `shbake export --to webgl` (index.html beside it): orbit controls around the
// sphere, the pass and material settings, the asset's parameters (as text, never markup).
import { drawPass, loadShbake, PASSES } from "./shbake_webgl.mjs";

const GLOSSY = new Set(["splitsum", "shexp"]);
const $ = (id) => document.getElementById(id);

function camera(yaw, pitch) {
  const back = [Math.sin(yaw) * Math.cos(pitch), Math.sin(pitch), Math.cos(yaw) * Math.cos(pitch)];
  const right = [Math.cos(yaw), 0, -Math.sin(yaw)];  // normalize(cross(+Y, back))
  const up = [
    back[1] * right[2] - back[2] * right[1],
    back[2] * right[0] - back[0] * right[2],
    back[0] * right[1] - back[1] * right[0],
  ];
  return [...right, ...up, ...back];
}

async function main() {
  const canvas = $("view");
  const gl = canvas.getContext("webgl2");
  if (!gl) throw new Error("this browser has no WebGL2");
  const asset = await loadShbake(gl, new URL("./", import.meta.url));
  const m = asset.manifest;
  const params = { name: m.asset.name, kind: m.asset.kind, ...m.asset.parameters };
  for (const [k, v] of Object.entries(params)) {
    const dt = document.createElement("dt");
    const dd = document.createElement("dd");
    dt.textContent = k;
    dd.textContent = typeof v === "object" ? JSON.stringify(v) : String(v);
    $("parameters").append(dt, dd);
  }
  for (const p of m.passes.filter((p) => p in PASSES)) $("pass").append(new Option(p, p));
  let yaw = 0, pitch = 0, drag = null;
  const draw = () => {
    const pass = $("pass").value;
    const r = Number($("roughness").value);
    $("roughness-value").textContent = r.toFixed(2);
    const size = Math.min(canvas.width, canvas.height);
    gl.bindFramebuffer(gl.FRAMEBUFFER, null);
    gl.clearColor(0, 0, 0, 1);
    gl.clear(gl.COLOR_BUFFER_BIT);
    const f0 = Number($("f0").value);
    drawPass(gl, asset, pass, {
      viewport: [(canvas.width - size) / 2, (canvas.height - size) / 2, size],
      camera: camera(yaw, pitch),
      alpha: GLOSSY.has(pass) ? r * r : 0,
      f0: [f0, f0, f0],
      display: true,
      exposure: 2 ** Number($("exposure").value),
    });
    const err = gl.getError();
    if (err !== gl.NO_ERROR) throw new Error(`WebGL error ${err}`);
  };
  canvas.addEventListener("pointerdown", (e) => { drag = [e.clientX, e.clientY]; canvas.setPointerCapture(e.pointerId); });
  canvas.addEventListener("pointerup", () => { drag = null; });
  canvas.addEventListener("pointermove", (e) => {
    if (!drag) return;
    yaw -= (e.clientX - drag[0]) * 0.01;
    pitch = Math.max(-1.55, Math.min(1.55, pitch + (e.clientY - drag[1]) * 0.01));
    drag = [e.clientX, e.clientY];
    requestAnimationFrame(draw);
  });
  $("controls").addEventListener("input", () => requestAnimationFrame(draw));
  draw();
  document.body.dataset.state = "ready";
}

main().catch((e) => {
  $("status").textContent = `error: ${e.message}`;
  document.body.dataset.state = "error";
  console.error(e);
});
