// shbake's own GLSL passes (tests/system/test_webgl_shaders.py, bench/shader_cost.py): loads an
// `export --to webgl` folder with the loader it carries (DIR/shbake_webgl.mjs) and draws each
// requested pass with the preview's camera (identity: orthographic from +Z) into a float32
// render target of `size`² pixels, returned as images; or, with `timing` (frames), into a
// `width` x `height` target filled by the sphere (a square of the frame's diagonal centred on
// it: every pixel runs the pass), returning milliseconds per frame (after one warm-up frame
// that compiles the program; each frame ends with a 1-pixel read-back, so it is finished).
import { encodeRows } from "./common.mjs";

const IDENTITY = [1, 0, 0, 0, 1, 0, 0, 0, 1];

window.shbakeRender = async function (p) {
  const { loadShbake, drawPass } = await import(p.dir + "shbake_webgl.mjs");
  const gl = document.getElementById("c").getContext("webgl2");
  if (!gl.getExtension("EXT_color_buffer_float")) throw new Error("no float render target");
  const asset = await loadShbake(gl, new URL(p.dir, location.href));
  const width = p.timing ? p.width : p.size;
  const height = p.timing ? p.height : p.size;
  const tex = gl.createTexture();
  gl.bindTexture(gl.TEXTURE_2D, tex);
  gl.texStorage2D(gl.TEXTURE_2D, 1, gl.RGBA32F, width, height);
  const fb = gl.createFramebuffer();
  gl.bindFramebuffer(gl.FRAMEBUFFER, fb);
  gl.framebufferTexture2D(gl.FRAMEBUFFER, gl.COLOR_ATTACHMENT0, gl.TEXTURE_2D, tex, 0);
  const pixels = new Float32Array(width * height * 4);
  const diagonal = Math.ceil(Math.hypot(width, height)) + 2;
  const viewport = p.timing ? [(width - diagonal) / 2, (height - diagonal) / 2, diagonal] : [0, 0, p.size];
  const out = {};
  for (const job of p.jobs) {
    const draw = () => {
      gl.clearColor(0, 0, 0, 0);
      gl.clear(gl.COLOR_BUFFER_BIT);
      drawPass(gl, asset, job.pass, { viewport, camera: job.camera || IDENTITY, alpha: job.alpha,
                                      f0: job.f0, reuse: job.reuse && out[job.name] !== undefined });
    };
    if (!p.timing) {
      draw();
      gl.readPixels(0, 0, width, height, gl.RGBA, gl.FLOAT, pixels);
      out[job.name] = encodeRows(pixels, width, height);
      continue;
    }
    const one = new Float32Array(4);
    draw();
    gl.readPixels(0, 0, 1, 1, gl.RGBA, gl.FLOAT, one);
    out[job.name] = 0;
    const t0 = performance.now();
    for (let k = 0; k < p.timing; k++) {
      draw();
      gl.readPixels(width >> 1, height >> 1, 1, 1, gl.RGBA, gl.FLOAT, one);
    }
    out[job.name] = (performance.now() - t0) / p.timing;
  }
  return { images: p.timing ? undefined : out, ms: p.timing ? out : undefined, glError: gl.getError() };
};
