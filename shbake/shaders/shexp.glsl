// shbake shexp: the SH-exponential glossy probe, shbake's v2 (Silvennoinen, Ikonen, Lehtinen
// et al. 2025, "SH-exponential" glossy probes, section 4), GGX of width alpha, Schlick F0.
// Needs common.glsl and dfg.glsl. CPU twin: shbake.shading.shexp.ShexpShader (the
// registry's and the preview's `shexp`).
//
//   E0(v, n, alpha) = P(rho, alpha) Q(h_rho, alpha)                         (eq. 9-11)
//   P = exp(sum_lm vMF_l y_lm(rho) p_lm(alpha)),  Q = exp(sum_lm vMF_l y_lm(h_rho) q_lm(alpha))
//   vMF_l = exp(-l(l+1) alpha / 2)                                          (eq. 12)
//   rho = 2(n.v)n - v,  h_rho = (n + rho)/|n + rho|                          (eq. 10)
//   E = F0 E0 + (1 - F0) E1                                                (eq. 5)
//   E1 = P(rho, alpha) Q(rho, alpha) A1(n.v, alpha) / A0(1, alpha)  (the tail at the mirror
//        direction at normal incidence, as split-sum reads it; replaces eq. 15's E0 A1/A0)
// p(alpha) = sum_k h_k(alpha) p_k: piecewise-linear hats on the knots (alpha clamped to
// them; at most two sets blend). q has no DC term.
//
// p, q: RGBA32F coefficient textures (common.glsl, shbakeCoeff): set k of probe j is set
// j K + k (K = knotCount); q's coefficient 0, its DC, is zero; knots increasing (K in [1, 8]).

// The two sets around alpha and the blend between them: shbake.shading.shexp.hat_weight.
void shbakeHat(float knots[8], int knotCount, float alpha, out int k0, out int k1, out float t) {
  k0 = 0;
  k1 = 0;
  t = 0.0;
  if (knotCount == 1) return;
  float a = clamp(alpha, knots[0], knots[knotCount - 1]);
  while (k0 < knotCount - 2 && a > knots[k0 + 1]) k0++;
  k1 = k0 + 1;
  t = (a - knots[k0]) / (knots[k1] - knots[k0]);
}

vec3 shbakeShexp(highp sampler2D p, int lmaxP, highp sampler2D q, int lmaxQ, float knots[8],
                 int knotCount, int probe, highp sampler2DArray dfg, vec3 v, vec3 n, float alpha,
                 vec3 f0) {
  float nv = dot(n, v);
  vec3 rho = 2.0 * nv * n - v;
  vec3 h = normalize(n + rho);
  int k0, k1;
  float t;
  shbakeHat(knots, knotCount, alpha, k0, k1, t);
  int base = probe * knotCount;
  vec3 logP = shbakeSHBlend(p, base + k0, base + k1, t, alpha, lmaxP, rho);
  vec3 e0 = exp(logP + shbakeSHBlend(q, base + k0, base + k1, t, alpha, lmaxQ, h));
  vec3 e0Mirror = exp(logP + shbakeSHBlend(q, base + k0, base + k1, t, alpha, lmaxQ, rho));
  float a0Normal = shbakeDFG(dfg, 1.0, alpha).x;
  float tail = a0Normal > 0.0 ? shbakeDFG(dfg, nv, alpha).y / a0Normal : 0.0;
  return f0 * e0 + (1.0 - f0) * e0Mirror * tail;
}
