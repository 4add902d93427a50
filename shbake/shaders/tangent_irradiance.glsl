// shbake tangent_irradiance: Kajiya-Kay diffuse irradiance of hair with unit tangent t
// (Mehta, Ramamoorthi, Meyer & Hery 2012, "Analytic tangent irradiance environment maps
// for anisotropic surfaces"). Needs common.glsl. CPU twins: shbake.shading.env_sh.
// TangentSHShader (the SH form, the registry's `tangent-sh`) and TangentShader (the matrix
// form, the registry's `tangent`), the preview's passes of the same names.
//
// SH form (Mehta eq. 13-15: the Kajiya-Kay kernel's coefficients A_l folded into E_i):
//   E(t) = sum_i E_i y_i(t) + sum_k sqrt(1 - (t.s_k)^2)/pi^2 E_k
// Matrix form (Mehta eq. 23-24: the bands l <= 2 as a quadratic form, per channel):
//   E(t) = [t,1]^T M [t,1] + sum_k sqrt(1 - (t.s_k)^2)/pi^2 E_k
// s_k, E_k as in irradiance.glsl.

// Kajiya-Kay diffuse factor of a directional light, c = t.s: shbake.shading.env_sh.sun_tangent.
float shbakeSunTangent(float c) {
  return sqrt(max(0.0, 1.0 - c * c)) / (SHBAKE_PI * SHBAKE_PI);
}

vec3 shbakeTangentLights(vec3 t, vec3 lightDir[SHBAKE_MAX_LIGHTS], vec3 lightE[SHBAKE_MAX_LIGHTS],
                         int lightCount) {
  vec3 e = vec3(0.0);
  for (int k = 0; k < lightCount; k++) e += shbakeSunTangent(dot(t, lightDir[k])) * lightE[k];
  return e;
}

// tangentSH: RGBA32F, texel i = E_i (/tangent_irradiance/sh), lmax its lmax.
vec3 shbakeTangentIrradianceSH(highp sampler2D tangentSH, int lmax, vec3 t,
                               vec3 lightDir[SHBAKE_MAX_LIGHTS], vec3 lightE[SHBAKE_MAX_LIGHTS],
                               int lightCount) {
  return shbakeSH(tangentSH, lmax, t) + shbakeTangentLights(t, lightDir, lightE, lightCount);
}

// M[c]: the 4x4 matrix of channel c (/tangent_irradiance/matrix[c]) as a GLSL mat4 (column j
// = column j of M: uniformMatrix4fv with transpose false takes M^T in row-major order).
vec3 shbakeTangentIrradianceMatrix(mat4 M[3], vec3 t,
                                   vec3 lightDir[SHBAKE_MAX_LIGHTS], vec3 lightE[SHBAKE_MAX_LIGHTS],
                                   int lightCount) {
  vec4 tt = vec4(t, 1.0);
  vec3 e = vec3(dot(tt, M[0] * tt), dot(tt, M[1] * tt), dot(tt, M[2] * tt));
  return e + shbakeTangentLights(t, lightDir, lightE, lightCount);
}
