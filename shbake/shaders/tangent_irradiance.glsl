// shbake tangent_irradiance: Kajiya-Kay diffuse irradiance of hair with unit tangent t
// (Mehta, Ramamoorthi, Meyer & Hery 2012, "Analytic tangent irradiance environment maps
// for anisotropic surfaces"). Needs common.glsl. CPU twins: shbake.shading.env_sh.
// TangentSHShader (the SH form, the registry's `tangent-sh`) and TangentShader (the matrix
// form, the registry's `tangent`), the preview's passes of the same names. Needs
// irradiance.glsl too (shbakeSphereLambert) for sphere lights.
//
// SH form (Mehta eq. 13-15: the Kajiya-Kay kernel's coefficients A_l folded into E_i):
//   E(t) = sum_i E_i y_i(t) + sum_k sqrt(1 - (t.s_k)^2)/pi^2 E_k
// Matrix form (Mehta eq. 23-24: the bands l <= 2 as a quadratic form, per channel):
//   E(t) = [t,1]^T M [t,1] + sum_k sqrt(1 - (t.s_k)^2)/pi^2 E_k
// s_k, E_k, lightRadius as in irradiance.glsl; a sphere light's factor is shbakeSphereTangent.

// Kajiya-Kay diffuse factor of a directional light, c = t.s: shbake.shading.env_sh.sun_tangent.
float shbakeSunTangent(float c) {
  return sqrt(max(0.0, 1.0 - c * c)) / (SHBAKE_PI * SHBAKE_PI);
}

// The same averaged over a sphere light of angular radius sigma (radians), c = t.s:
// J(s, sigma)/pi^2, s = sqrt(1 - c^2), J = s sin(phi1) + the integral over [phi1, pi/2] of
// K(s cos phi) + K(-s cos phi) (K = shbakeSphereLambert) by 8-point Gauss-Legendre.
// CPU twin: shbake.shading.sphere_light.sphere_tangent.
const float SHBAKE_GL8_X[4] = float[4](0.1834346424956498, 0.5255324099163290,
                                       0.7966664774136267, 0.9602898564975363);
const float SHBAKE_GL8_W[4] = float[4](0.3626837833783620, 0.3137066458778873,
                                       0.2223810344533745, 0.1012285362903763);
float shbakeSphereTangent(float c, float sigma) {
  float s = sqrt(max(0.0, 1.0 - c * c));
  float b = sin(sigma);
  float start = s > b ? acos(min(1.0, b / s)) : 0.0;
  float half_ = (0.5 * SHBAKE_PI - start) * 0.5;
  float j = s > b ? s * sin(start) : 0.0;
  for (int i = 0; i < 4; i++) {
    for (int sgn = -1; sgn <= 1; sgn += 2) {
      float u = s * cos(start + half_ * (1.0 + float(sgn) * SHBAKE_GL8_X[i]));
      j += half_ * SHBAKE_GL8_W[i] * (shbakeSphereLambert(u, sigma) + shbakeSphereLambert(-u, sigma));
    }
  }
  return j / (SHBAKE_PI * SHBAKE_PI);
}

vec3 shbakeTangentLights(vec3 t, vec3 lightDir[SHBAKE_MAX_LIGHTS], vec3 lightE[SHBAKE_MAX_LIGHTS],
                         int lightCount, float lightRadius[SHBAKE_MAX_LIGHTS]) {
  vec3 e = vec3(0.0);
  for (int k = 0; k < lightCount; k++) {
    float c = dot(t, lightDir[k]);
    e += (lightRadius[k] > 0.0 ? shbakeSphereTangent(c, lightRadius[k]) : shbakeSunTangent(c)) * lightE[k];
  }
  return e;
}

// tangentSH: RGBA32F, texel i = E_i (/tangent_irradiance/sh), lmax its lmax.
vec3 shbakeTangentIrradianceSH(highp sampler2D tangentSH, int lmax, vec3 t,
                               vec3 lightDir[SHBAKE_MAX_LIGHTS], vec3 lightE[SHBAKE_MAX_LIGHTS],
                               int lightCount, float lightRadius[SHBAKE_MAX_LIGHTS]) {
  return shbakeSH(tangentSH, lmax, t) + shbakeTangentLights(t, lightDir, lightE, lightCount, lightRadius);
}

// M[c]: the 4x4 matrix of channel c (/tangent_irradiance/matrix[c]) as a GLSL mat4 (column j
// = column j of M: uniformMatrix4fv with transpose false takes M^T in row-major order).
vec3 shbakeTangentIrradianceMatrix(mat4 M[3], vec3 t,
                                   vec3 lightDir[SHBAKE_MAX_LIGHTS], vec3 lightE[SHBAKE_MAX_LIGHTS],
                                   int lightCount, float lightRadius[SHBAKE_MAX_LIGHTS]) {
  vec4 tt = vec4(t, 1.0);
  vec3 e = vec3(dot(tt, M[0] * tt), dot(tt, M[1] * tt), dot(tt, M[2] * tt));
  return e + shbakeTangentLights(t, lightDir, lightE, lightCount, lightRadius);
}
