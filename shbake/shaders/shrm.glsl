// shbake shrm: shading with a Spherical Harmonic Reflection Map (Ramamoorthi & Hanrahan 2002,
// "Frequency space environment map rendering", section 7.5). Needs common.glsl. CPU twins:
// shbake.shading.shrm.ShrmShader (reflection_cube and shade; the registry's and the
// preview's `shrm`), shbake.texture.cube.cube_bilinear (the seam-correct fetch).
//
// Eq. 12, the reflection cube map for a distant viewer V (unit, toward the eye), read at
// the reflection vector R = 2(n.V)n - V:
//   B(R) = sum_{p <= P} sum_s B_ps(R) y_ps(V)                       (surface, lobe kinds)
// and, for the tangent kind (Kajiya-Kay), at the fibre tangent T, the cube texel at
// direction d holding B_p0:
//   B(T) = sum_{p <= P} B_p0(d) y_p0(d.V)
// Here each texel's eq. 12 value is formed where the fetch reads it (one pass, no cube
// render target): the 4 bilinear taps around the lookup direction, each beyond the face's
// border replaced by a clamped bilinear fetch of the face holding that (extended) texel
// centre, so the result is continuous across edges and corners (GL_TEXTURE_CUBE_MAP_SEAMLESS).
//
// shrm: coefficient texture (common.glsl, shbakeCoeff), set (face S + row) S + column the
// texel's n = (P+1)^2 coefficients (tangent kind: B_p0 at index p(p+1), zero elsewhere);
// faces +X, -X, +Y, -Y, +Z, -Z (OpenEXR envmap = cube), row i at t = 2(i+1/2)/S - 1 top to
// bottom, column j at s = 2(j+1/2)/S - 1; faces[f]: the face's matrix A, direction = A (s, t, 1)
// (shbake.conventions.CUBE_FACES, as the mat3 whose columns are A's).

// Face and continuous texel coordinates (column x, row y) of a non-zero direction (ties go
// to the first face in strip order): shbake.texture.cube.cube_address.
void shbakeCubeAddress(mat3 faces[6], int size, vec3 d, out int face, out float x, out float y) {
  vec3 a = abs(d);
  if (a.x >= a.y && a.x >= a.z) face = d.x > 0.0 ? 0 : 1;
  else if (a.y >= a.z) face = d.y > 0.0 ? 2 : 3;
  else face = d.z > 0.0 ? 4 : 5;
  vec3 uwk = transpose(faces[face]) * d;
  x = 0.5 * (uwk.x / uwk.z + 1.0) * float(size) - 0.5;
  y = 0.5 * (uwk.y / uwk.z + 1.0) * float(size) - 0.5;
}

// Direction of the centre of texel (i, j) of `face`, extended past the border for i, j
// outside [0, size).
vec3 shbakeCubeTexelDirection(mat3 faces[6], int size, int face, int i, int j) {
  return faces[face] * vec3(2.0 * (float(j) + 0.5) / float(size) - 1.0,
                            2.0 * (float(i) + 0.5) / float(size) - 1.0, 1.0);
}

// Eq. 12 at one texel.
vec3 shbakeShrmTexel(highp sampler2D shrm, int P, bool tangentKind, mat3 faces[6], int size,
                     int face, int i, int j, vec3 V) {
  int set = (face * size + i) * size + j;
  vec3 d = V;
  if (tangentKind) {
    float x = clamp(dot(normalize(shbakeCubeTexelDirection(faces, size, face, i, j)), V), -1.0, 1.0);
    d = vec3(sqrt(1.0 - x * x), 0.0, x);  // y_p0(x): m = 0 only
  }
  return shbakeSHBlend(shrm, set, set, 0.0, 0.0, P, d);
}

// Bilinear eq. 12 inside one face, coordinates clamped to its texel centres.
vec3 shbakeShrmClamped(highp sampler2D shrm, int P, bool tangentKind, mat3 faces[6], int size,
                       int face, float x, float y, vec3 V) {
  int i0, i1, j0, j1;
  float fy, fx;
  shbakeAxis(y, size, i0, i1, fy);
  shbakeAxis(x, size, j0, j1, fx);
  return shbakeBlend(vec4(shbakeShrmTexel(shrm, P, tangentKind, faces, size, face, i0, j0, V), 0.0),
                     vec4(shbakeShrmTexel(shrm, P, tangentKind, faces, size, face, i0, j1, V), 0.0),
                     vec4(shbakeShrmTexel(shrm, P, tangentKind, faces, size, face, i1, j0, V), 0.0),
                     vec4(shbakeShrmTexel(shrm, P, tangentKind, faces, size, face, i1, j1, V), 0.0),
                     fy, fx).rgb;
}

// The reflection cube of eq. 12 for view V, read seam-correctly at direction `dir` (R, or T
// for the tangent kind).
vec3 shbakeShrm(highp sampler2D shrm, int P, bool tangentKind, mat3 faces[6], int size,
                vec3 dir, vec3 V) {
  int face;
  float x, y;
  shbakeCubeAddress(faces, size, dir, face, x, y);
  int j0 = int(floor(x)), i0 = int(floor(y));
  float fx = x - float(j0), fy = y - float(i0);
  vec3 out3 = vec3(0.0);
  for (int di = 0; di < 2; di++) {
    float wy = di == 1 ? fy : 1.0 - fy;
    for (int dj = 0; dj < 2; dj++) {
      float w = (dj == 1 ? fx : 1.0 - fx) * wy;
      if (w == 0.0) continue;
      int i = i0 + di, j = j0 + dj;
      if (i >= 0 && i < size && j >= 0 && j < size) {
        out3 += w * shbakeShrmTexel(shrm, P, tangentKind, faces, size, face, i, j, V);
      } else {
        int f2;
        float x2, y2;
        shbakeCubeAddress(faces, size, shbakeCubeTexelDirection(faces, size, face, i, j), f2, x2, y2);
        out3 += w * shbakeShrmClamped(shrm, P, tangentKind, faces, size, f2, x2, y2, V);
      }
    }
  }
  return out3;
}
