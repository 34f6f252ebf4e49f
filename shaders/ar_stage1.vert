// Hybrid apparent ridges, object-space stage (seed 000, listing A.1).
// Static attributes: position, normal, (k1, k2), e1, e2.
layout(location = 0) in vec3 a_position;
layout(location = 1) in vec3 a_normal;
layout(location = 2) in vec2 a_curvature;
layout(location = 3) in vec3 a_e1;
layout(location = 4) in vec3 a_e2;
uniform mat4 u_model_view;
uniform mat4 u_projection;
uniform mat3 u_normal_matrix;
#ifdef PER_FRAGMENT
out vec3 v_position;
out vec3 v_normal;
out vec3 v_s_diagonal;   // S_xx, S_yy, S_zz (eye space)
out vec3 v_s_off;        // S_xy, S_xz, S_yz
#else
out vec3 v_packed;
#endif
void main() {
  vec4 V = u_model_view * vec4(a_position, 1.0);
  gl_Position = to_tile(u_projection * V);
  clip_at(a_position);
  vec3 N = normalize(u_normal_matrix * a_normal);
  vec3 e1 = u_normal_matrix * a_e1;
  vec3 e2 = u_normal_matrix * a_e2;
#ifdef PER_FRAGMENT
  v_position = V.xyz;
  v_normal = N;
  float k1 = a_curvature.x, k2 = a_curvature.y;
  v_s_diagonal = k1 * e1 * e1 + k2 * e2 * e2;
  v_s_off = k1 * vec3(e1.x * e1.y, e1.x * e1.z, e1.y * e1.z) +
            k2 * vec3(e2.x * e2.y, e2.x * e2.z, e2.y * e2.z);
#else
  v_packed = apparent_ridge_vertex(V.xyz, N, e1, e2, a_curvature.x, a_curvature.y);
#endif
}
