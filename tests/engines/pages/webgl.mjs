// shbake's own GLSL passes (tests/test_webgl_shaders.py): loads an `export --to webgl` folder
// with the loader it carries (DIR/shbake_webgl.mjs) and draws each requested pass with the
// preview's camera (identity: orthographic from +Z) into a float32 render target.
import { encodeRows } from "./common.mjs";

const IDENTITY = [1, 0, 0, 0, 1, 0, 0, 0, 1];

window.shbakeRender = async function (p) {
  const { loadShbake, drawPass } = await import(p.dir + "shbake_webgl.mjs");
  const gl = document.getElementById("c").getContext("webgl2");
  if (!gl.getExtension("EXT_color_buffer_float")) throw new Error("no float render target");
  const asset = await loadShbake(gl, new URL(p.dir, location.href));
  const tex = gl.createTexture();
  gl.bindTexture(gl.TEXTURE_2D, tex);
  gl.texStorage2D(gl.TEXTURE_2D, 1, gl.RGBA32F, p.size, p.size);
  const fb = gl.createFramebuffer();
  gl.bindFramebuffer(gl.FRAMEBUFFER, fb);
  gl.framebufferTexture2D(gl.FRAMEBUFFER, gl.COLOR_ATTACHMENT0, gl.TEXTURE_2D, tex, 0);
  const pixels = new Float32Array(p.size * p.size * 4);
  const images = {};
  for (const job of p.jobs) {
    gl.clearColor(0, 0, 0, 0);
    gl.clear(gl.COLOR_BUFFER_BIT);
    drawPass(gl, asset, job.pass, { viewport: [0, 0, p.size], camera: job.camera || IDENTITY,
                                    alpha: job.alpha, f0: job.f0 });
    gl.readPixels(0, 0, p.size, p.size, gl.RGBA, gl.FLOAT, pixels);
    images[job.name] = encodeRows(pixels, p.size, p.size);
  }
  return { images, glError: gl.getError() };
};
