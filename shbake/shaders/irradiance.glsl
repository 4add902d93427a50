// shbake irradiance: SH irradiance of an env_sh asset plus its directional lights.
// Needs common.glsl. CPU twin: shbake.shading.env_sh.IrradianceShader, the registry's
// `irradiance` (the preview's `irradiance` pass shows E(n)/pi: a white Lambert sphere).
//
//   E(n) = sum_i E_i y_i(n) + sum_k max(0, n.s_k) E_k   (sphere lights: shbakeSphereLambert)
//
// E_i = A_l w_l L_i, the Lambert kernel A_0 = pi, A_1 = 2pi/3, A_2 = pi/4 (Ramamoorthi &
// Hanrahan 2001, "An efficient representation for irradiance environment maps", eq. 8-9;
// any stored lmax, L2 the engine case); s_k, E_k: the extracted sun (/sun: direction and
// radiance x solid angle) or the fitted lights (/lights), in radiance x sr.
//
// irradiance: RGBA32F, texel i = E_i (RGB), lmax: the stored irradiance lmax;
// lightDir/lightE/lightCount: unit vectors toward the lights and their irradiance;
// lightRadius: their angular radii in radians (/lights/angular_radius; 0: a point).
// Sphere light of angular radius sigma (radians, [0, pi/2)) per unit irradiance at normal
// incidence, c = n.s: max(0, c) away from the horizon, the horizon-clipped cap within
// +-sigma of it (Snyder 1996; Lagarde & de Rousiers 2014 eq. 17, with the terms of order
// sin(sigma) that cancel taken out). CPU twin: shbake.shading.sphere_light.sphere_lambert.
float shbakeSphereLambert(float c, float sigma) {
  float sinS = sin(sigma);
  if (abs(c) >= sinS) return max(c, 0.0);
  float cosS = cos(sigma);
  float sinT = sqrt(1.0 - c * c);
  float y = clamp(-(cosS / sinS) * c / sinT, -1.0, 1.0);
  float root = sqrt(max(0.0, 1.0 - y * y));
  float z = sinT * root * sinS / cosS;
  float w = z * z;
  float q = (sinT * root / cosS) * (sinT * root / cosS);  // z^2 / sin^2(sigma)
  float h = w < 0.01 ? -1.0 / 3.0 + w * (1.0 / 5.0 + w * (-1.0 / 7.0 + w / 9.0))
                     : (atan(z) / z - 1.0) / w;
  return (c * acos(y) + z + z * q * h) / SHBAKE_PI;
}

vec3 shbakeIrradiance(highp sampler2D irradiance, int lmax, vec3 n,
                      vec3 lightDir[SHBAKE_MAX_LIGHTS], vec3 lightE[SHBAKE_MAX_LIGHTS], int lightCount,
                      float lightRadius[SHBAKE_MAX_LIGHTS]) {
  vec3 e = shbakeSH(irradiance, lmax, n);
  for (int k = 0; k < lightCount; k++) e += shbakeSphereLambert(dot(n, lightDir[k]), lightRadius[k]) * lightE[k];
  return e;
}
