// Anti-aliased line coverage, fading by strength, hidden-line test against a
// depth texture (linear eye depth, tolerance in mm; the largest depth of a
// small cross is used so lines on silhouettes are not hidden by the surface
// they lie on). u_hidden_mode: 0 omit, 1 dashed, 2 draw.
uniform vec4 u_line_color;
uniform int u_fade_by_strength;
uniform sampler2D u_depth;
// 1: the scene's depth is the nearer of u_depth and u_depth2 (the ghosts'
// nearest depth drawn with their transparency, at u_depth's resolution).
uniform sampler2D u_depth2;
uniform int u_two_depths;
uniform int u_hidden_mode;
uniform float u_hidden_opacity;
uniform float u_depth_tolerance;
// 1: u_depth is at half resolution (ghosts while the camera moves).
uniform int u_depth_shift;
uniform vec2 u_near_far;
uniform int u_orthographic;
uniform float u_dash_px;
in float v_across;
in float v_half_width;
in float v_strength;
in float v_arc_px;
layout(location = 0) out vec4 o_color;
float linear_depth(float z) {
  float n = u_near_far.x, f = u_near_far.y;
  if (u_orthographic == 1) return n + z * (f - n);
  float zn = 2.0 * z - 1.0;
  return 2.0 * n * f / (f + n - zn * (f - n));
}
// The scene's depth at texel q (clamped to the texture).
float scene_depth(ivec2 q, ivec2 size) {
  q = clamp(q, ivec2(0), size);
  float d = texelFetch(u_depth, q, 0).r;
  if (u_two_depths == 1) d = min(d, texelFetch(u_depth2, q, 0).r);
  return d;
}
void main() {
  float coverage = clamp(v_half_width + 0.5 - abs(v_across), 0.0, 1.0);
  if (coverage <= 0.0) discard;
  ivec2 p = ivec2(gl_FragCoord.xy) >> u_depth_shift;
  ivec2 size = textureSize(u_depth, 0) - 1;
  float scene = 0.0;
  scene = max(scene, scene_depth(p, size));
  scene = max(scene, scene_depth(p + ivec2(1, 0), size));
  scene = max(scene, scene_depth(p + ivec2(-1, 0), size));
  scene = max(scene, scene_depth(p + ivec2(0, 1), size));
  scene = max(scene, scene_depth(p + ivec2(0, -1), size));
  bool hidden = scene < 1.0 && linear_depth(gl_FragCoord.z) > linear_depth(scene) + u_depth_tolerance;
  float alpha = u_line_color.a * coverage * cutaway().x;
  if (u_fade_by_strength == 1) alpha *= clamp(v_strength, 0.0, 1.0);
  if (hidden) {
    if (u_hidden_mode == 0) discard;
    if (u_hidden_mode == 1 && mod(v_arc_px, 2.0 * u_dash_px) > u_dash_px) discard;
    alpha *= u_hidden_opacity;
  }
  if (alpha <= 0.0) discard;
  o_color = vec4(u_line_color.rgb * alpha, alpha);
}
