// shbake splitsum: the split-sum baseline (Karis 2013, "Real shading in Unreal Engine 4",
// eq. 4-5 and the environment BRDF), GGX of width alpha, Schlick F0. Needs common.glsl and
// dfg.glsl. CPU twin: shbake.shading.splitsum.SplitsumShader (the registry's and the
// preview's `splitsum`).
//
//   E(v, n, alpha) = Lpre(rho, alpha) (F0 A0(n.v, alpha) + (1 - F0) A1(n.v, alpha)),
//   rho = 2(n.v)n - v,
// Lpre read bilinearly from the two octahedral levels whose GGX widths bracket alpha,
// linear in alpha between them (clamped to the levels).
//
// levels: RGBA32F array, layer k holds level k (size levelSize[k]) in texels [0, size)^2,
// rows as stored (row 0 first); levelAlpha increasing; levelCount in [2, 16].

// Octahedral texture coordinates (u columns, w rows) of unit d, about +Y (Cigolle et al.
// 2014): shbake.texture.octahedral.encode.
vec2 shbakeOctEncode(vec3 d) {
  float s = abs(d.x) + abs(d.y) + abs(d.z);
  vec2 p = d.xz / s;
  if (d.y < 0.0) {
    p = vec2((1.0 - abs(p.y)) * (p.x >= 0.0 ? 1.0 : -1.0), (1.0 - abs(p.x)) * (p.y >= 0.0 ? 1.0 : -1.0));
  }
  return 0.5 * (p + 1.0);
}

// Bilinear octahedral fetch of a level: shbake.texture.octahedral.fetch.
vec3 shbakeOctFetch(highp sampler2DArray levels, int layer, int size, vec3 d) {
  vec2 uw = shbakeOctEncode(d);
  return shbakeBilinear(levels, layer, size, size, uw.y * float(size) - 0.5, uw.x * float(size) - 0.5).rgb;
}

vec3 shbakeSplitSum(highp sampler2DArray levels, int levelSize[16], float levelAlpha[16], int levelCount,
                    highp sampler2DArray dfg, vec3 v, vec3 n, float alpha, vec3 f0) {
  float nv = dot(n, v);
  vec3 rho = 2.0 * nv * n - v;
  float a = clamp(alpha, levelAlpha[0], levelAlpha[levelCount - 1]);
  int i0 = 0;
  while (i0 < levelCount - 2 && a > levelAlpha[i0 + 1]) i0++;
  float t = (a - levelAlpha[i0]) / (levelAlpha[i0 + 1] - levelAlpha[i0]);
  vec3 pre = (1.0 - t) * shbakeOctFetch(levels, i0, levelSize[i0], rho)
           + t * shbakeOctFetch(levels, i0 + 1, levelSize[i0 + 1], rho);
  vec2 ab = shbakeDFG(dfg, nv, alpha);
  return pre * (f0 * ab.x + (1.0 - f0) * ab.y);
}
