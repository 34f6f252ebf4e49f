// Surface LIC, stage 1 (docs/algorithms.md §14): per visible front-facing
// fragment of a LIC structure (depth test EQUAL against the opaque pass's
// depth, back faces culled), the screen direction recovered from the
// interpolated doubled-angle vector (the half angle, sign chosen with
// y >= 0), the solid noise at the fragment's object-space position and the
// feature mask clamp(phi, 0, 1), stored as RGBA8: (dir * 0.5 + 0.5, noise,
// mask); all zero (mask 0) where there is no direction.
uniform float u_inv_cell;
in vec3 v_object;
in float v_level;
in vec2 v_doubled;
layout(location = 0) out vec4 o_data;
void main() {
  cutaway_discard();
  float noise = lic_noise(v_object * u_inv_cell);
  float mask = clamp(v_level, 0.0, 1.0);
  float len = length(v_doubled);
  if (!(len > 1e-4) || !(mask > 0.0)) {
    o_data = vec4(0.5, 0.5, noise, 0.0);
    return;
  }
  float c = clamp(v_doubled.x / len, -1.0, 1.0);
  vec2 d = vec2(sqrt(0.5 * (1.0 + c)), sqrt(0.5 * (1.0 - c)));
  if (v_doubled.y < 0.0) d.y = -d.y;
  o_data = vec4(d * 0.5 + 0.5, noise, mask);
}
