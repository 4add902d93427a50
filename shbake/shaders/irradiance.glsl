// shbake irradiance: SH irradiance of an env_sh asset plus its directional lights.
// Needs common.glsl. CPU twin: shbake.shading.env_sh.IrradianceShader, the registry's
// `irradiance` (the preview's `irradiance` pass shows E(n)/pi: a white Lambert sphere).
//
//   E(n) = sum_i E_i y_i(n) + sum_k max(0, n.s_k) E_k
//
// E_i = A_l w_l L_i, the Lambert kernel A_0 = pi, A_1 = 2pi/3, A_2 = pi/4 (Ramamoorthi &
// Hanrahan 2001, "An efficient representation for irradiance environment maps", eq. 8-9;
// any stored lmax, L2 the engine case); s_k, E_k: the extracted sun (/sun: direction and
// radiance x solid angle) or the fitted lights (/lights), in radiance x sr.
//
// irradiance: RGBA32F, texel i = E_i (RGB), lmax: the stored irradiance lmax;
// lightDir/lightE/lightCount: unit vectors toward the lights and their irradiance.
vec3 shbakeIrradiance(highp sampler2D irradiance, int lmax, vec3 n,
                      vec3 lightDir[SHBAKE_MAX_LIGHTS], vec3 lightE[SHBAKE_MAX_LIGHTS], int lightCount) {
  vec3 e = shbakeSH(irradiance, lmax, n);
  for (int k = 0; k < lightCount; k++) e += max(0.0, dot(n, lightDir[k])) * lightE[k];
  return e;
}
