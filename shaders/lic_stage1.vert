// Surface LIC, stage 1 (docs/algorithms.md §14): the object-space position,
// for the surface-attached noise; the feature level phi (linear in a face);
// and the vertex's maximal-curvature line direction projected to the screen
// as a doubled-angle vector (cos 2a, sin 2a) of its screen angle a, so that
// interpolating it across a face does not depend on the direction's sign
// (zero where the direction is missing or seen end-on). u_mvp is the whole
// image's object-to-clip matrix, u_image_size its size: the angle is in
// pixels of the whole image, the same in every tile.
layout(location = 0) in vec3 a_position;
layout(location = 5) in float a_level;
layout(location = 6) in vec3 a_direction;
uniform mat4 u_model_view;
uniform mat4 u_projection;
uniform mat4 u_mvp;
uniform vec2 u_image_size;
out vec3 v_object;
out float v_level;
out vec2 v_doubled;
void main() {
  v_object = a_position;
  v_level = a_level;
  vec4 c = u_mvp * vec4(a_position, 1.0);
  vec4 dc = u_mvp * vec4(a_direction, 0.0);
  vec2 s = vec2((dc.x * c.w - c.x * dc.w) * u_image_size.x, (dc.y * c.w - c.y * dc.w) * u_image_size.y);
  float l2 = dot(s, s);
  v_doubled = l2 > 0.0 ? vec2(s.x * s.x - s.y * s.y, 2.0 * s.x * s.y) / l2 : vec2(0.0);
  clip_at(a_position);  // the scene's clipping plane, as the opaque pass
  vec4 p = u_model_view * vec4(a_position, 1.0);
  gl_Position = to_tile(u_projection * p);  // as mesh.vert: the depth test is EQUAL
}
