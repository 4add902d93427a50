// shbake's WebGL2 loader (`shbake export ASSET --to webgl -o DIR` copies it into DIR): reads
// DIR/shbake.json, its KTX2 textures and GLSL files, and draws the asset's passes on a unit
// sphere seen orthographically (the geometry of `shbake preview`, shbake/preview/sphere.py,
// turned by a camera rotation). Raw WebGL2, no dependency. docs/SHADERS.md describes the
// files; the viewer (DIR/index.html) and the rendered tests (tests/system/test_webgl_shaders.py)
// both draw through drawPass.

const HEADER = `#version 300 es
precision highp float;
precision highp int;
precision highp sampler2D;
precision highp sampler2DArray;
`;

// Per pass: the function `vec3 shade(vec3 n, vec3 v, vec3 t)` (world normal, unit vector
// toward the viewer, longitude-line tangent) and whether grazing pixels (n.v <= 1e-3) are
// left black, as the preview's glossy passes do (the probe shaders' min_nv, shbake.shading).
const LIGHTS = "uLightDir, uLightE, uLightCount, uLightRadius";
const KAUTZ = "uKautzTable, uKautzH, uKautzW, uKautzL, uKautzLmax";
const FRAME = "transpose(mat3(t, cross(n, t), n))";  // world -> local: rows t, b = n x t, n
const PIXEL = "ivec2(gl_FragCoord.xy - uViewport.xy)";
export const PASSES = {
  irradiance: {
    shade: `return shbakeIrradiance(uIrradiance, uIrradianceLmax, n, ${LIGHTS}) / SHBAKE_PI;`,
  },
  "tangent-sh": {
    shade: `return shbakeTangentIrradianceSH(uTangentSH, uTangentLmax, t, ${LIGHTS});`,
  },
  "tangent-matrix": {
    shade: `return shbakeTangentIrradianceMatrix(uTangentM, t, ${LIGHTS});`,
  },
  splitsum: {
    grazing: true,
    shade: "return shbakeSplitSum(uLevels, uLevelSize, uLevelAlpha, uLevelCount, uDFG, v, n, uAlpha, uF0);",
  },
  shrm: {
    shade: "return shbakeShrm(uShrm, uShrmP, uShrmTangent == 1, uCubeFaces, uShrmSize, "
      + "uShrmTangent == 1 ? t : 2.0 * dot(n, v) * n - v, v);",
  },
  kautz: { shade: `return shbakeKautz(${KAUTZ}, ${FRAME}, v);` },
  // The fixed modes: `prepare` writes coefficient uCoeff of the stored per-pixel vector into
  // layer uCoeff of uStore (once while the light, or the view, stays fixed); `shade` is the
  // per-frame work.
  "kautz-fixed-light": {
    prepare: `return shbakeKautzStored(${KAUTZ}, ${FRAME}, v, uCoeff, false);`,
    shade: `return shbakeKautzFixedLight(uKautzTable, uKautzH, uKautzW, uKautzLmax, uStore, ${PIXEL}, ${FRAME}, v);`,
  },
  "kautz-fixed-view": {
    prepare: `return shbakeKautzStored(${KAUTZ}, ${FRAME}, v, uCoeff, true);`,
    shade: `return shbakeKautzFixedView(uKautzL, uKautzLmax, uStore, ${PIXEL});`,
  },
  shexp: {
    grazing: true,
    shade: "return shbakeShexp(uP, uLmaxP, uQ, uLmaxQ, uKnots, uKnotCount, uProbe, uDFG, v, n, uAlpha, uF0);",
  },
};

const GLSL_TYPE = {
  int: "int", float: "float", vec3: "vec3", "int[]": "int", "float[]": "float", "vec3[]": "vec3",
  "mat3[]": "mat3", "mat4[]": "mat4",
};

function declarations(manifest) {
  const out = [];
  for (const [name, t] of Object.entries(manifest.textures)) {
    out.push(`uniform highp ${t.layers ? "sampler2DArray" : "sampler2D"} ${name};`);
  }
  for (const [name, u] of Object.entries(manifest.uniforms)) {
    out.push(`uniform ${GLSL_TYPE[u.type]} ${name}${u.type.endsWith("[]") ? `[${u.length}]` : ""};`);
  }
  return out.join("\n");
}

/** The fragment shader of `pass` (`stage` "prepare": its stored coefficients): header, the
 * asset's uniforms, the GLSL files, the pass. */
export function fragmentSource(asset, pass, stage = "shade") {
  const p = PASSES[pass];
  return `${HEADER}
uniform mat3 uCamera;    // world <- camera: columns right, up, toward the viewer
uniform vec4 uViewport;  // x, y of the square's lower-left corner, its size in pixels
uniform float uAlpha;    // GGX width
uniform vec3 uF0;        // Schlick reflectance
uniform float uExposure;
uniform int uDisplay;    // 0: linear radiance out; 1: exposure, tone map, sRGB-like gamma
uniform int uCoeff;      // the coefficient a "prepare" stage writes
uniform highp sampler2DArray uStore;  // what it wrote, layer i = coefficient i
out vec4 fragColor;
${declarations(asset.manifest)}
${asset.sources.join("\n")}
vec3 shade(vec3 n, vec3 v, vec3 t) { ${stage === "prepare" ? p.prepare : p.shade} }
void main() {
  vec2 p = 2.0 * (gl_FragCoord.xy - uViewport.xy) / uViewport.z - 1.0;
  float r2 = dot(p, p);
  vec3 n = uCamera * vec3(p, sqrt(max(0.0, 1.0 - r2)));
  vec3 v = uCamera[2];
  if (r2 >= 1.0${p.grazing ? " || dot(n, v) <= 1e-3" : ""}) discard;  // the clear colour shows
  vec3 t = vec3(0.0, 1.0, 0.0) - n.y * n;  // +Y projected on the tangent plane
  t = length(t) > 1e-12 ? normalize(t) : vec3(1.0, 0.0, 0.0);
  vec3 c = shade(n, v, t);
  fragColor = uDisplay == 1 && ${stage !== "prepare"} ? vec4(pow(vec3(1.0) - exp(-uExposure * c), vec3(1.0 / 2.2)), 1.0)
                            : vec4(c, 1.0);
}
`;
}

const VERTEX = `${HEADER}
void main() { gl_Position = vec4(gl_VertexID == 1 ? 3.0 : -1.0, gl_VertexID == 2 ? 3.0 : -1.0, 0.0, 1.0); }
`;

const KTX2_IDENTIFIER = [0xab, 0x4b, 0x54, 0x58, 0x20, 0x32, 0x30, 0xbb, 0x0d, 0x0a, 0x1a, 0x0a];
const KTX2_FORMATS = {  // vkFormat -> typeSize, WebGL2 internal format and type, texel array
  109: { typeSize: 4, internalFormat: "RGBA32F", type: "FLOAT", array: Float32Array },  // R32G32B32A32_SFLOAT
  97: { typeSize: 2, internalFormat: "RGBA16F", type: "HALF_FLOAT", array: Uint16Array },  // R16G16B16A16_SFLOAT
};

/** The texels of a KTX 2.0 file (KTX 2.0 spec §3: header, level index) as the export writes
 * them: RGBA32F (or RGBA16F), a 2D texture or 2D array, one level, no supercompression.
 * Anything else is refused with an error naming `name` and what it holds. */
export function parseKtx2(buffer, name) {
  const fail = (why) => { throw new Error(`${name}: ${why}`); };
  const bytes = new Uint8Array(buffer);
  if (bytes.length < 104 || KTX2_IDENTIFIER.some((b, i) => bytes[i] !== b)) fail("not a KTX2 file");
  const view = new DataView(buffer);
  const [vkFormat, typeSize, width, height, depth, layers, faces, levels, scheme] =
    Array.from({ length: 9 }, (_, i) => view.getUint32(12 + 4 * i, true));
  const format = KTX2_FORMATS[vkFormat];
  if (!format || typeSize !== format.typeSize) {
    fail(`vkFormat ${vkFormat} (typeSize ${typeSize}); shbake reads R32G32B32A32_SFLOAT (109) or R16G16B16A16_SFLOAT (97)`);
  }
  if (depth !== 0 || faces !== 1) fail(`pixelDepth ${depth}, faceCount ${faces}: not a 2D texture or 2D array`);
  if (levels !== 1 || scheme !== 0) fail(`levelCount ${levels}, supercompressionScheme ${scheme}: not one uncompressed level`);
  const offset = Number(view.getBigUint64(80, true));
  const length = Number(view.getBigUint64(88, true));
  if (length !== width * height * Math.max(layers, 1) * 4 * typeSize || offset % typeSize !== 0
      || offset + length > bytes.length) {
    fail(`level 0 (${length} bytes at ${offset}) is not ${width} x ${height} x ${Math.max(layers, 1)} RGBA texels in the file`);
  }
  return { width, height, layers, ...format, data: new format.array(buffer, offset, length / typeSize) };
}

// BEGIN snippet webgl
// Load an export: its manifest, KTX2 textures (RGBA32F, nearest: the shaders filter) and GLSL.
export async function loadShbake(gl, base) {
  const get = async (name) => {
    const r = await fetch(new URL(name, base));
    if (!r.ok) throw new Error(`${name}: HTTP ${r.status}`);
    return r;
  };
  const manifest = await (await get("shbake.json")).json();
  const textures = {};
  for (const [name, t] of Object.entries(manifest.textures)) {
    const k = parseKtx2(await (await get(t.file)).arrayBuffer(), t.file);
    if (k.width !== t.width || k.height !== t.height || k.layers !== (t.layers || 0)) {
      throw new Error(`${t.file}: ${k.width} x ${k.height} x ${k.layers} layers, not the manifest's size`);
    }
    const [target, format, type] = [k.layers ? gl.TEXTURE_2D_ARRAY : gl.TEXTURE_2D, gl[k.internalFormat], gl[k.type]];
    const tex = gl.createTexture();
    gl.bindTexture(target, tex);
    if (k.layers) gl.texImage3D(target, 0, format, k.width, k.height, k.layers, 0, gl.RGBA, type, k.data);
    else gl.texImage2D(target, 0, format, k.width, k.height, 0, gl.RGBA, type, k.data);
    for (const p of [gl.TEXTURE_MIN_FILTER, gl.TEXTURE_MAG_FILTER]) gl.texParameteri(target, p, gl.NEAREST);
    textures[name] = { target, tex };
  }
  const sources = await Promise.all(manifest.shaders.map(async (f) => (await get(f)).text()));
  return { manifest, textures, sources, programs: {}, stores: {} };
}
// END snippet webgl

function compile(gl, type, source) {
  const s = gl.createShader(type);
  gl.shaderSource(s, source);
  gl.compileShader(s);
  if (!gl.getShaderParameter(s, gl.COMPILE_STATUS)) throw new Error(gl.getShaderInfoLog(s));
  return s;
}

function program(gl, asset, pass, stage) {
  const key = `${pass}/${stage}`;
  if (asset.programs[key]) return asset.programs[key];
  const prog = gl.createProgram();
  gl.attachShader(prog, compile(gl, gl.VERTEX_SHADER, VERTEX));
  gl.attachShader(prog, compile(gl, gl.FRAGMENT_SHADER, fragmentSource(asset, pass, stage)));
  gl.linkProgram(prog);
  if (!gl.getProgramParameter(prog, gl.LINK_STATUS)) throw new Error(gl.getProgramInfoLog(prog));
  asset.programs[key] = prog;
  return prog;
}

// The per-pixel store of a pass with a "prepare" stage: an RGBA32F array texture, one layer
// per SH coefficient of the table (kautz fixed modes), size x size pixels.
function store(gl, asset, pass, size) {
  const layers = (asset.manifest.uniforms.uKautzLmax.value + 1) ** 2;
  const old = asset.stores[pass];
  if (old && old.size === size) return old;
  if (!gl.getExtension("EXT_color_buffer_float")) throw new Error("no float render target");
  const tex = gl.createTexture();
  gl.bindTexture(gl.TEXTURE_2D_ARRAY, tex);
  gl.texStorage3D(gl.TEXTURE_2D_ARRAY, 1, gl.RGBA32F, size, size, layers);
  for (const p of [gl.TEXTURE_MIN_FILTER, gl.TEXTURE_MAG_FILTER]) {
    gl.texParameteri(gl.TEXTURE_2D_ARRAY, p, gl.NEAREST);  // float32: complete only unfiltered
  }
  asset.stores[pass] = { tex, size, layers, fb: gl.createFramebuffer() };
  return asset.stores[pass];
}

function bindInputs(gl, asset, prog, settings) {
  let unit = 0;
  for (const [name, t] of Object.entries(asset.textures)) {
    gl.activeTexture(gl.TEXTURE0 + unit);
    gl.bindTexture(t.target, t.tex);
    gl.uniform1i(gl.getUniformLocation(prog, name), unit++);
  }
  for (const [name, u] of Object.entries(asset.manifest.uniforms)) {
    setUniform(gl, gl.getUniformLocation(prog, name), u);
  }
  const { viewport, camera, alpha, f0, display, exposure } = settings;
  gl.uniformMatrix3fv(gl.getUniformLocation(prog, "uCamera"), false, camera);
  gl.uniform4f(gl.getUniformLocation(prog, "uViewport"), viewport[0], viewport[1], viewport[2], 0);
  gl.uniform1f(gl.getUniformLocation(prog, "uAlpha"), alpha);
  gl.uniform3fv(gl.getUniformLocation(prog, "uF0"), f0);
  gl.uniform1f(gl.getUniformLocation(prog, "uExposure"), exposure);
  gl.uniform1i(gl.getUniformLocation(prog, "uDisplay"), display ? 1 : 0);
  return unit;
}

function setUniform(gl, loc, u) {
  if (loc === null) return;  // declared but not read by this pass
  const v = u.value;
  if (u.type === "int" || u.type === "int[]") gl.uniform1iv(loc, [].concat(v));
  else if (u.type === "float" || u.type === "float[]") gl.uniform1fv(loc, [].concat(v));
  else if (u.type === "vec3" || u.type === "vec3[]") gl.uniform3fv(loc, v.flat());
  else if (u.type === "mat3[]") gl.uniformMatrix3fv(loc, false, v.flat(2));
  else if (u.type === "mat4[]") gl.uniformMatrix4fv(loc, false, v.flat(2));
}

/**
 * Draw `pass` into the bound framebuffer's square `viewport` [x, y, size]: `camera` a
 * column-major world <- camera rotation (9 numbers; identity: the preview's view from +Z),
 * `alpha` the GGX width, `f0` Schlick reflectance (RGB), `display` tone-maps for a screen.
 * A pass with a "prepare" stage (kautz fixed light / fixed view) first fills its per-pixel
 * store, unless `reuse` (the light, or the view, has not changed since).
 */
export function drawPass(gl, asset, pass, { viewport, camera, alpha = 0.25, f0 = [1, 1, 1],
                                            display = false, exposure = 1.0, reuse = false }) {
  const settings = { viewport, camera, alpha, f0, display, exposure };
  let stored = null;
  if (PASSES[pass].prepare) {
    stored = store(gl, asset, pass, viewport[2]);
    if (!reuse) {
      const target = gl.getParameter(gl.FRAMEBUFFER_BINDING);
      const prog = program(gl, asset, pass, "prepare");
      gl.useProgram(prog);
      bindInputs(gl, asset, prog, { ...settings, viewport: [0, 0, viewport[2]], display: false });
      gl.bindFramebuffer(gl.FRAMEBUFFER, stored.fb);
      gl.viewport(0, 0, stored.size, stored.size);
      for (let i = 0; i < stored.layers; i++) {
        gl.framebufferTextureLayer(gl.FRAMEBUFFER, gl.COLOR_ATTACHMENT0, stored.tex, 0, i);
        gl.clearBufferfv(gl.COLOR, 0, [0, 0, 0, 0]);
        gl.uniform1i(gl.getUniformLocation(prog, "uCoeff"), i);
        gl.drawArrays(gl.TRIANGLES, 0, 3);
      }
      gl.bindFramebuffer(gl.FRAMEBUFFER, target);
    }
  }
  const prog = program(gl, asset, pass, "shade");
  gl.useProgram(prog);
  const unit = bindInputs(gl, asset, prog, settings);
  if (stored) {
    gl.activeTexture(gl.TEXTURE0 + unit);
    gl.bindTexture(gl.TEXTURE_2D_ARRAY, stored.tex);
    gl.uniform1i(gl.getUniformLocation(prog, "uStore"), unit);
  }
  gl.viewport(viewport[0], viewport[1], viewport[2], viewport[2]);
  gl.drawArrays(gl.TRIANGLES, 0, 3);
}
