// Mesh vertex stage: eye-space position and normal for headlight shading.
layout(location = 0) in vec3 a_position;
layout(location = 1) in vec3 a_normal;
uniform mat4 u_model_view;
uniform mat4 u_projection;
uniform mat3 u_normal_matrix;
out vec3 v_position;
out vec3 v_normal;
void main() {
  vec4 p = u_model_view * vec4(a_position, 1.0);
  v_position = p.xyz;
  v_normal = u_normal_matrix * a_normal;
  gl_Position = to_tile(u_projection * p);
  clip_at(a_position);
}
