// Benchmark baseline: the same attributes and passes as the hybrid method
// with trivial arithmetic.
layout(location = 0) in vec3 a_position;
layout(location = 1) in vec3 a_normal;
layout(location = 2) in vec2 a_curvature;
layout(location = 3) in vec3 a_e1;
layout(location = 4) in vec3 a_e2;
uniform mat4 u_model_view;
uniform mat4 u_projection;
out vec3 v_packed;
void main() {
  gl_Position = to_tile(u_projection * (u_model_view * vec4(a_position, 1.0)));
  v_packed = vec3(a_curvature.x, a_normal.x + a_e1.x, a_e2.x);
}
