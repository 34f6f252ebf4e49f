// Hybrid apparent ridges: writes (q, t1 packed, coverage 1) into the
// off-screen target. Occluders (other opaque structures) are drawn by
// ar_occluder.frag.
#ifdef PER_FRAGMENT
in vec3 v_position;
in vec3 v_normal;
in vec3 v_s_diagonal;
in vec3 v_s_off;
#else
in vec3 v_packed;
#endif
layout(location = 0) out vec4 o_data;
void main() {
  cutaway_discard();
#ifdef PER_FRAGMENT
  mat3 S = mat3(v_s_diagonal.x, v_s_off.x, v_s_off.y,
                v_s_off.x, v_s_diagonal.y, v_s_off.z,
                v_s_off.y, v_s_off.z, v_s_diagonal.z);
  o_data = vec4(apparent_ridge_fragment(v_position, v_normal, S), 1.0);
#else
  o_data = vec4(v_packed, 1.0);
#endif
}
