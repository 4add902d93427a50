// shbake dfg: the DFG table (A0, A1) of every probe asset (/dfg, shbake.bakers.dfg): the
// split-sum environment BRDF (Karis 2013) of GGX with Schlick Fresnel,
//   A0 = int f_DV (n.l) dl,  A1 = int f_DV (1 - v.h)^5 (n.l) dl.
// Needs common.glsl. CPU twin: shbake.shading.dfg.dfg_at.
//
// dfg: RGBA32F array, layer 0, row i = n.v node i, column j = sqrt(alpha) node j; RG = A0, A1.
// Node-centred axes: n.v in [SHBAKE_DFG_MU_MIN, 1], sqrt(alpha) in [SHBAKE_ROUGHNESS_MIN, 1],
// queries clamped to them.
const float SHBAKE_DFG_MU_MIN = 1e-3;       // shbake.conventions.DFG_MU_MIN
const float SHBAKE_ROUGHNESS_MIN = 0.02;    // shbake.conventions.ROUGHNESS_MIN

vec2 shbakeDFG(highp sampler2DArray dfg, float mu, float alpha) {
  ivec3 s = textureSize(dfg, 0);
  float r = sqrt(max(alpha, 0.0));
  float x = (min(1.0, max(SHBAKE_DFG_MU_MIN, mu)) - SHBAKE_DFG_MU_MIN) / (1.0 - SHBAKE_DFG_MU_MIN) * float(s.y - 1);
  float y = (min(1.0, max(SHBAKE_ROUGHNESS_MIN, r)) - SHBAKE_ROUGHNESS_MIN) / (1.0 - SHBAKE_ROUGHNESS_MIN) * float(s.x - 1);
  return shbakeBilinear(dfg, 0, s.y, s.x, x, y).rg;
}
