// shbake common GLSL ES 3.00 (WebGL2 / OpenGL ES 3): included before every technique file.
// Conventions (docs/CONVENTIONS.md, SPEC §1-2): real orthonormal SH, no Condon-Shortley
// phase, flat index i = l(l+1)+m, theta from +Z, phi from +X toward +Y; world right-handed,
// +Y up; radiance linear Rec.709; irradiance in radiance x sr.
// Textures (docs/SHADERS.md): RGBA32F read with texelFetch only (float32 is not filterable
// in core WebGL2, and hardware filter weights carry 8 fractional bits): every bilinear fetch
// below is the one rule of shbake/texture/bilinear.py, done in float32 arithmetic.

const float SHBAKE_PI = 3.14159265358979;
const int SHBAKE_MAX_LIGHTS = 8;  // shbake.bakers.env_lights.MAX_LIGHTS

// Clamped bilinear taps of continuous index x on an axis of n samples (texel k at x = k):
// CPU twin shbake.texture.bilinear.axis.
void shbakeAxis(float x, int n, out int i0, out int i1, out float f) {
  x = clamp(x, 0.0, float(n - 1));
  i0 = n > 1 ? min(int(x), n - 2) : 0;
  i1 = min(i0 + 1, n - 1);
  f = x - float(i0);
}

// Bilinear blend, fy along rows, fx along columns: shbake.texture.bilinear.blend.
vec4 shbakeBlend(vec4 t00, vec4 t01, vec4 t10, vec4 t11, float fy, float fx) {
  return (1.0 - fy) * ((1.0 - fx) * t00 + fx * t01) + fy * ((1.0 - fx) * t10 + fx * t11);
}

// Bilinear fetch of layer `layer` of an array texture whose texels [0, rows) x [0, cols) hold
// a table, at continuous row y and column x (texel centres at integers), edges clamped.
vec4 shbakeBilinear(highp sampler2DArray tex, int layer, int rows, int cols, float y, float x) {
  int i0, i1, j0, j1;
  float fy, fx;
  shbakeAxis(y, rows, i0, i1, fy);
  shbakeAxis(x, cols, j0, j1, fx);
  return shbakeBlend(texelFetch(tex, ivec3(j0, i0, layer), 0), texelFetch(tex, ivec3(j1, i0, layer), 0),
                     texelFetch(tex, ivec3(j0, i1, layer), 0), texelFetch(tex, ivec3(j1, i1, layer), 0),
                     fy, fx);
}

// Coefficient i of set `set` of a coefficient texture: sets of n = (lmax+1)^2 coefficients
// stored one after the other, element k = set n + i at texel (k mod width, k div width); RGB.
vec3 shbakeCoeff(highp sampler2D tex, int n, int set, int i) {
  int w = textureSize(tex, 0).x;
  int k = set * n + i;
  return texelFetch(tex, ivec2(k % w, k / w), 0).rgb;
}

// sum_i c_i y_i(d) for i < (lmax+1)^2, d unit, with
//   c_i = exp(-l(l+1) vmfAlpha / 2) ((1 - t) C_{set0,i} + t C_{set1,i})
// (vmfAlpha = 0, t = 0: the coefficients as stored; shexp.glsl blends two sets and
// applies the vMF band factor). The normalised recurrence of shbake.sh.basis
// (Q_l^m = Pbar_l^m / sin^m theta):
//   Q_m^m = sqrt((2m+1)/(2m)) Q_{m-1}^{m-1},  Q_0^0 = 1/sqrt(4 pi)
//   Q_l^m = a_lm (z Q_{l-1}^m - b_lm Q_{l-2}^m),
//   a_lm = sqrt((4l^2-1)/(l^2-m^2)),  b_lm = sqrt(((l-1)^2-m^2)/(4(l-1)^2-1)),
// y_l0 = Q_l^0, y_l+-m = sqrt(2) Q_l^m Re/Im (x + i y)^m (no (-1)^m). CPU twin:
// shbake.sh.basis.evaluate.
vec3 shbakeSHBlend(highp sampler2D coeffs, int set0, int set1, float t, float vmfAlpha, int lmax,
                   vec3 d) {
  int n = (lmax + 1) * (lmax + 1);
  vec3 sum = vec3(0.0);
  float qmm = 0.28209479177387814;  // 1/sqrt(4 pi)
  float cm = 1.0, sm = 0.0;          // Re, Im (x + i y)^m
  for (int m = 0; m <= lmax; m++) {
    if (m > 0) {
      qmm *= sqrt(float(2 * m + 1) / float(2 * m));
      float c = cm * d.x - sm * d.y;
      sm = cm * d.y + sm * d.x;
      cm = c;
    }
    float q2 = 0.0, q1 = qmm;  // Q_{l-2}^m, Q_{l-1}^m
    for (int l = m; l <= lmax; l++) {
      float q = q1;
      if (l > m) {
        float fl = float(l), fm = float(m);
        float a = sqrt((4.0 * fl * fl - 1.0) / (fl * fl - fm * fm));
        float b = sqrt(max(0.0, ((fl - 1.0) * (fl - 1.0) - fm * fm) / (4.0 * (fl - 1.0) * (fl - 1.0) - 1.0)));
        q = a * (d.z * q1 - b * q2);
        q2 = q1;
        q1 = q;
      }
      q *= exp(-float(l * (l + 1)) * vmfAlpha * 0.5);
      int base = l * (l + 1);
      if (m == 0) {
        sum += q * mix(shbakeCoeff(coeffs, n, set0, base), shbakeCoeff(coeffs, n, set1, base), t);
      } else {
        float s2q = 1.4142135623730951 * q;
        sum += s2q * cm * mix(shbakeCoeff(coeffs, n, set0, base + m), shbakeCoeff(coeffs, n, set1, base + m), t)
             + s2q * sm * mix(shbakeCoeff(coeffs, n, set0, base - m), shbakeCoeff(coeffs, n, set1, base - m), t);
      }
    }
  }
  return sum;
}

// sum_i c_i y_i(d), c_i the coefficients as stored (set 0).
vec3 shbakeSH(highp sampler2D coeffs, int lmax, vec3 d) {
  return shbakeSHBlend(coeffs, 0, 0, 0.0, 0.0, lmax, d);
}
