// Surface LIC, stage 1 (docs/algorithms.md §14): per visible fragment of a
// LIC structure, the maximal-curvature direction of its triangle (texture
// buffer, 4 floats per triangle: direction in object space, 1 or 0 for a
// degenerate face) projected to the screen and normalised, the solid noise
// at the fragment's object-space position, and the feature mask
// clamp(phi, 0, 1). Output (dir.x, dir.y, noise, mask); mask 0 where the
// projection degenerates. u_mvp is the whole image's
// object-to-clip matrix, u_image_size its size: the direction is in
// pixels of the whole image, the same in every tile.
uniform samplerBuffer u_field;
uniform mat4 u_mvp;
uniform vec2 u_image_size;
uniform float u_inv_cell;
in vec3 v_object;
in float v_level;
layout(location = 0) out vec4 o_data;
void main() {
  cutaway_discard();
  vec4 f = texelFetch(u_field, gl_PrimitiveID);
  float noise = lic_noise(v_object * u_inv_cell);
  vec4 c = u_mvp * vec4(v_object, 1.0);
  vec4 dc = u_mvp * vec4(f.xyz, 0.0);
  vec2 s = vec2((dc.x * c.w - c.x * dc.w) * u_image_size.x, (dc.y * c.w - c.y * dc.w) * u_image_size.y);
  float len = length(s);
  float mask = clamp(v_level, 0.0, 1.0);
  if (!(len > 0.0) || !(f.w > 0.0) || !(mask > 0.0)) {
    o_data = vec4(0.0, 0.0, noise, 0.0);
    return;
  }
  o_data = vec4(s / len, noise, mask);
}
