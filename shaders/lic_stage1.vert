// Surface LIC, stage 1 (and its occluders): the object-space position, for
// the surface-attached noise and the field's projection.
layout(location = 0) in vec3 a_position;
uniform mat4 u_model_view;
uniform mat4 u_projection;
out vec3 v_object;
void main() {
  v_object = a_position;
  gl_Position = to_tile(u_projection * (u_model_view * vec4(a_position, 1.0)));
}
