// shbake kautz: a BRDF table shaded under SH lighting (Kautz, Sloan & Snyder 2002, "Fast,
// arbitrary BRDF shading for low-frequency lighting using spherical harmonics", section 4:
// rotate, fetch, dot). Needs common.glsl. CPU twin: shbake.shading.brdf_table.KautzShader
// (shade_full; the registry's and the preview's `kautz`, its three modes), the rotation of
// shbake.sh.rotation (Ivanic & Ruedenberg 1996, with the 1998 erratum), the parabolic fetch
// of shbake.texture.parabolic (Heidrich & Seidel 1999).
//
// Per pixel with world -> local frame R (rows: tangent, bitangent, normal) and local view
// v = R V:
//   Q = sum_i (M(R) L)_i c_i(v)
// L: the world lighting coefficients (the sun or fitted lights folded in as SH of delta
// lights, band-limited like the rest: shading.brdf_table.lighting_with_sun); M(R): the SH
// rotation, y(R d) = M(R) y(d), built band by band from the l = 1 block (R permuted to the
// basis order (y, z, x)) and the previous band's block; c(v): the table's coefficients at
// v, bilinear in the parabolic map (p = (v_x, v_y)/(1 + v_z), texel centres (k+1/2)/size,
// views below the horizon read the rim). This is the paper's per-pixel "full" mode; the
// fixed-light and fixed-view modes store M(R)L, or M(R)^T c(v), per pixel and dot them with
// the other factor: the same sums, reordered.
//
// table: coefficient texture, set y W + x the n = (lmax+1)^2 coefficients of parabolic
// texel (row y, column x) of an H x W map; lighting: coefficient texture, set 0 = L.
// lmax <= SHBAKE_KAUTZ_LMAX.

const int SHBAKE_KAUTZ_LMAX = 8;
const int SHBAKE_KAUTZ_BLOCK = (2 * SHBAKE_KAUTZ_LMAX + 1) * (2 * SHBAKE_KAUTZ_LMAX + 1);

// Bilinear parabolic taps of unit local view v in an h x w map: shbake.texture.parabolic.taps.
void shbakeParabolicTaps(int h, int w, vec3 v, out int y0, out int y1, out float fy,
                         out int x0, out int x1, out float fx) {
  float z = max(v.z, 0.0);
  shbakeAxis((v.y / (1.0 + z) + 1.0) * 0.5 * float(h) - 0.5, h, y0, y1, fy);
  shbakeAxis((v.x / (1.0 + z) + 1.0) * 0.5 * float(w) - 0.5, w, x0, x1, fx);
}

// Coefficient i of c(v), bilinear between the 4 taps' sets s (rows fy, columns fx).
vec3 shbakeKautzCoeff(highp sampler2D table, int n, ivec4 s, float fy, float fx, int i) {
  return shbakeBlend(vec4(shbakeCoeff(table, n, s.x, i), 0.0), vec4(shbakeCoeff(table, n, s.y, i), 0.0),
                     vec4(shbakeCoeff(table, n, s.z, i), 0.0), vec4(shbakeCoeff(table, n, s.w, i), 0.0),
                     fy, fx).rgb;
}

// P(i, a, b) of Ivanic-Ruedenberg (shbake.sh.rotation.rotation_blocks_many): i in {-1, 0, 1},
// |a| < l, |b| <= l, from the l = 1 block r1 (r1[i+1][j+1], basis order (y, z, x)) and the
// previous band's block prev ((2l-1)^2, row-major, row a + l - 1).
float shbakeRotP(mat3 r1, float prev[SHBAKE_KAUTZ_BLOCK], int l, int i, int a, int b) {
  int ps = 2 * l - 1, row = (a + l - 1) * ps;
  vec3 ri = vec3(r1[0][i + 1], r1[1][i + 1], r1[2][i + 1]);  // row i of r1 (column-major mat3)
  if (b == l) return ri.z * prev[row + ps - 1] - ri.x * prev[row];
  if (b == -l) return ri.z * prev[row] + ri.x * prev[row + ps - 1];
  return ri.y * prev[row + b + l - 1];
}

// The l = 1 block of M(R) for the world -> local frame (a GLSL mat3: frame * d is local):
// M_1[i][j] = R[p(i)][p(j)], p = (1, 2, 0), stored in r1 (r1[col][row]) and in `block`
// (row-major), where shbakeRotationStep carries it to higher bands.
mat3 shbakeRotationStart(mat3 frame, out float block[SHBAKE_KAUTZ_BLOCK]) {
  mat3 r1;
  for (int i = 0; i < 3; i++)
    for (int j = 0; j < 3; j++) r1[j][i] = frame[(j + 1) % 3][(i + 1) % 3];
  for (int k = 0; k < 9; k++) block[k] = r1[k % 3][k / 3];
  return r1;
}

// Band l's block ((2l+1)^2, row m + l, column n + l) from band l - 1's, in place (l >= 2):
// every entry u P(0, m, n) + v V + w W with the u, v, w factors and the P sums of
// Ivanic-Ruedenberg's table (shbake.sh.rotation.rotation_blocks_many).
void shbakeRotationStep(mat3 r1, int l, inout float block[SHBAKE_KAUTZ_BLOCK]) {
  float cur[SHBAKE_KAUTZ_BLOCK];
  int size = 2 * l + 1;
  for (int m = -l; m <= l; m++) {
    int am = abs(m);
    float d = m == 0 ? 1.0 : 0.0;
    for (int nn = -l; nn <= l; nn++) {
      float denom = abs(nn) < l ? float((l + nn) * (l - nn)) : float(2 * l * (2 * l - 1));
      float u = sqrt(float((l + m) * (l - m)) / denom);
      float vv = 0.5 * sqrt((1.0 + d) * float((l + am - 1) * (l + am)) / denom) * (1.0 - 2.0 * d);
      float ww = -0.5 * sqrt(max(0.0, float((l - am - 1) * (l - am))) / denom) * (1.0 - d);
      float val = 0.0;
      if (u != 0.0) val += u * shbakeRotP(r1, block, l, 0, m, nn);
      if (vv != 0.0) {
        if (m == 0) {
          val += vv * (shbakeRotP(r1, block, l, 1, 1, nn) + shbakeRotP(r1, block, l, -1, -1, nn));
        } else if (m > 0) {
          float t = shbakeRotP(r1, block, l, 1, m - 1, nn) * (m == 1 ? sqrt(2.0) : 1.0);
          if (m != 1) t -= shbakeRotP(r1, block, l, -1, -m + 1, nn);
          val += vv * t;
        } else {
          float t = shbakeRotP(r1, block, l, -1, -m - 1, nn) * (m == -1 ? sqrt(2.0) : 1.0);
          if (m != -1) t += shbakeRotP(r1, block, l, 1, m + 1, nn);
          val += vv * t;
        }
      }
      if (ww != 0.0) {
        if (m > 0) val += ww * (shbakeRotP(r1, block, l, 1, m + 1, nn) + shbakeRotP(r1, block, l, -1, -m - 1, nn));
        else val += ww * (shbakeRotP(r1, block, l, 1, m - 1, nn) - shbakeRotP(r1, block, l, -1, -m + 1, nn));
      }
      cur[(m + l) * size + nn + l] = val;
    }
  }
  for (int k = 0; k < size * size; k++) block[k] = cur[k];
}

// The table's bilinear taps at local view v: the 4 sets s and the blend (fy rows, fx columns).
void shbakeKautzTaps(int h, int w, vec3 v, out ivec4 s, out float fy, out float fx) {
  int y0, y1, x0, x1;
  shbakeParabolicTaps(h, w, v, y0, y1, fy, x0, x1, fx);
  s = ivec4(y0 * w + x0, y0 * w + x1, y1 * w + x0, y1 * w + x1);
}

// Full mode: Q = sum_i (M(R) L)_i c_i(v), band by band (M(R) L never stored).
vec3 shbakeKautz(highp sampler2D table, int h, int w, highp sampler2D lighting, int lmax,
                 mat3 frame, vec3 V) {
  int n = (lmax + 1) * (lmax + 1);
  ivec4 s;
  float fy, fx;
  shbakeKautzTaps(h, w, frame * V, s, fy, fx);
  vec3 q = shbakeCoeff(lighting, n, 0, 0) * shbakeKautzCoeff(table, n, s, fy, fx, 0);  // l = 0
  float block[SHBAKE_KAUTZ_BLOCK];
  mat3 r1 = shbakeRotationStart(frame, block);
  for (int l = 1; l <= lmax; l++) {
    if (l >= 2) shbakeRotationStep(r1, l, block);
    int size = 2 * l + 1, base = l * l;
    for (int m = 0; m < size; m++) {
      vec3 lp = vec3(0.0);
      for (int j = 0; j < size; j++) lp += block[m * size + j] * shbakeCoeff(lighting, n, 0, base + j);
      q += lp * shbakeKautzCoeff(table, n, s, fy, fx, base + m);
    }
  }
  return q;
}

// Coefficient i of the per-pixel vector the fixed modes store: (M(R) L)_i (fixed light:
// world = false) or (M(R)^T c(v))_i (fixed view: world = true).
vec3 shbakeKautzStored(highp sampler2D table, int h, int w, highp sampler2D lighting, int lmax,
                       mat3 frame, vec3 V, int i, bool world) {
  int n = (lmax + 1) * (lmax + 1);
  int l = int(floor(sqrt(float(i)) + 0.5));
  if (l * l > i) l--;
  int size = 2 * l + 1, base = l * l, m = i - base;
  ivec4 s;
  float fy, fx;
  shbakeKautzTaps(h, w, frame * V, s, fy, fx);
  float block[SHBAKE_KAUTZ_BLOCK];
  block[0] = 1.0;  // band 0
  if (l >= 1) {
    mat3 r1 = shbakeRotationStart(frame, block);
    for (int b = 2; b <= l; b++) shbakeRotationStep(r1, b, block);
  }
  vec3 out3 = vec3(0.0);
  for (int j = 0; j < size; j++) {
    out3 += world ? block[j * size + m] * shbakeKautzCoeff(table, n, s, fy, fx, base + j)
                  : block[m * size + j] * shbakeCoeff(lighting, n, 0, base + j);
  }
  return out3;
}

// Fixed light, per frame: sum_i Lp_i c_i(v), Lp = M(R) L read from `stored` (layer i, pixel).
vec3 shbakeKautzFixedLight(highp sampler2D table, int h, int w, int lmax, highp sampler2DArray stored,
                           ivec2 pixel, mat3 frame, vec3 V) {
  int n = (lmax + 1) * (lmax + 1);
  ivec4 s;
  float fy, fx;
  shbakeKautzTaps(h, w, frame * V, s, fy, fx);
  vec3 q = vec3(0.0);
  for (int i = 0; i < n; i++) q += texelFetch(stored, ivec3(pixel, i), 0).rgb * shbakeKautzCoeff(table, n, s, fy, fx, i);
  return q;
}

// Fixed view, per frame (a lighting change): sum_i L_i cw_i, cw = M(R)^T c(v) from `stored`.
vec3 shbakeKautzFixedView(highp sampler2D lighting, int lmax, highp sampler2DArray stored, ivec2 pixel) {
  int n = (lmax + 1) * (lmax + 1);
  vec3 q = vec3(0.0);
  for (int i = 0; i < n; i++) q += shbakeCoeff(lighting, n, 0, i) * texelFetch(stored, ivec3(pixel, i), 0).rgb;
  return q;
}
