// View-dependent curvature of Judd et al. (2007) as in seed 000 (Jardim &
// de Figueiredo 2011, listing A.1, with the errata of docs/algorithms.md §6.4 and
// Appendix A fixed): q1 is the largest eigenvalue of Q^T Q (q1 squared in
// Judd's notation, as rtsc and the seed store it; 1/mm^2), t1 its screen
// direction in eye-space xy, oriented so the 3D vector points away from the
// viewer.
uniform int u_orthographic;
uniform float u_scale;  // 2^tau
uniform float u_q_max;  // saturation (1 = the [0,1] colour range of the seed)
uniform int u_sign_free;

// Largest eigenvalue and eigenvector of the symmetric 2x2 Q^T Q.
float qtq_max(float Q11, float Q12, float Q21, float Q22, out vec2 s1) {
  float QTQ1 = Q11 * Q11 + Q21 * Q21;
  float QTQ12 = Q11 * Q12 + Q21 * Q22;
  float QTQ2 = Q12 * Q12 + Q22 * Q22;
  float a = QTQ12 * QTQ12, b = QTQ2 - QTQ1;
  float q1 = 0.5 * (QTQ1 + QTQ2);
  if (q1 > 0.0)
    q1 += sqrt(a + 0.25 * b * b);
  else
    q1 -= sqrt(a + 0.25 * b * b);
  // The seed's eigenvector (QTQ2 - q1, -QTQ12) vanishes when the answer is
  // (0, 1); the equivalent form from the first row of (Q^T Q - q1 I) does not.
  // Taking the longer of the two changes nothing where the seed's is well
  // conditioned (a numerical fix, not a change of method).
  vec2 s = vec2(QTQ2 - q1, -QTQ12);
  vec2 r = vec2(-QTQ12, QTQ1 - q1);
  if (dot(r, r) > dot(s, s)) s = r;
  s1 = dot(s, s) > 1.0e-30 ? normalize(s) : vec2(1.0, 0.0);  // umbilic: any direction
  return q1;
}

// Packs q and t1 for the image stage: (q, t1 encoded in [0,1]^2). With
// u_sign_free the double angle (cos 2phi, sin 2phi) is stored, which does not
// cancel when neighbouring vertices choose opposite signs of t1.
vec3 pack_q_t1(float q1, vec3 w1) {
  float q = clamp(u_scale * q1, 0.0, u_q_max);
  vec2 t1 = w1.z >= 0.0 ? -w1.xy : w1.xy;
  t1 = dot(t1, t1) > 1.0e-30 ? normalize(t1) : vec2(0.0, 0.0);
  if (u_sign_free == 1) t1 = vec2(t1.x * t1.x - t1.y * t1.y, 2.0 * t1.x * t1.y);
  return vec3(q, 0.5 + 0.5 * t1.x, 0.5 + 0.5 * t1.y);
}

// Per-vertex evaluation from n, k1, k2, e1, e2 (all in eye space).
vec3 apparent_ridge_vertex(vec3 V, vec3 N, vec3 e1, vec3 e2, float k1, float k2) {
  vec3 viewdir = u_orthographic == 1 ? vec3(0.0, 0.0, 1.0) : normalize(-V);
  float ndotv = dot(viewdir, N);
  float u = dot(viewdir, e1), v = dot(viewdir, e2);
  float u2 = u * u, v2 = v * v, uv = u * v;
  if (u2 + v2 < 1.0e-12) {  // looking along the normal: sec(theta) - 1 = 0, any w
    u2 = 1.0;
    v2 = 0.0;
    uv = 0.0;
  } else {
    float csc2theta = 1.0 / (u2 + v2);
    u2 *= csc2theta;
    v2 *= csc2theta;
    uv *= csc2theta;
  }
  float sectheta_minus1 = 1.0 / max(abs(ndotv), 1.0e-4) - 1.0;
  float Q11 = k1 * (1.0 + sectheta_minus1 * u2);
  float Q12 = k1 * (sectheta_minus1 * uv);
  float Q21 = k2 * (sectheta_minus1 * uv);
  float Q22 = k2 * (1.0 + sectheta_minus1 * v2);
  vec2 s1;
  float q1 = qtq_max(Q11, Q12, Q21, Q22, s1);
  vec3 w1 = s1.x * e1 + s1.y * e2;
  return pack_q_t1(q1, w1);
}

// Per-fragment evaluation ("Phong-like") from the interpolated normal and the
// interpolated eye-space shape operator S = k1 e1 e1^T + k2 e2 e2^T (sign-free,
// so it interpolates where e1 flips between vertices). In the tangent basis
// (w, n x w), P^{-1} = diag(sec theta, 1) and Q = S P^{-1}.
vec3 apparent_ridge_fragment(vec3 V, vec3 N, mat3 S) {
  vec3 n = normalize(N);
  vec3 view = u_orthographic == 1 ? vec3(0.0, 0.0, 1.0) : normalize(-V);
  float ndotv = dot(n, view);
  vec3 w = view - ndotv * n;
  vec3 b1;
  if (dot(w, w) > 1.0e-12) {
    b1 = normalize(w);
  } else {
    vec3 a = abs(n.x) < 0.9 ? vec3(1.0, 0.0, 0.0) : vec3(0.0, 1.0, 0.0);
    b1 = normalize(cross(n, a));
  }
  vec3 b2 = cross(n, b1);
  float s11 = dot(b1, S * b1), s12 = dot(b1, S * b2), s22 = dot(b2, S * b2);
  float sectheta = 1.0 / max(abs(ndotv), 1.0e-4);
  vec2 s1;
  float q1 = qtq_max(s11 * sectheta, s12, s12 * sectheta, s22, s1);
  vec3 w1 = s1.x * b1 + s1.y * b2;
  return pack_q_t1(q1, w1);
}
