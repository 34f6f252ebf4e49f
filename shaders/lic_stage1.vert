// Surface LIC, stage 1 (and its occluders): the object-space position, for
// the surface-attached noise and the field's projection, and the feature
// level phi (linear in a face; occluders have no such attribute: 0).
layout(location = 0) in vec3 a_position;
layout(location = 5) in float a_level;
out float v_level;
uniform mat4 u_model_view;
uniform mat4 u_projection;
out vec3 v_object;
void main() {
  v_object = a_position;
  v_level = a_level;
  clip_at(a_position);  // the scene's clipping plane, as the opaque pass
  gl_Position = to_tile(u_projection * (u_model_view * vec4(a_position, 1.0)));
}
