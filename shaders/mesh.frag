// Opaque mesh: premultiplied colour with alpha 1 (cut context dropped, its
// rim drawn: cutaway.glsl).
layout(location = 0) out vec4 o_color;
void main() {
  vec2 cut = cutaway();
  if (cut.x < 1.0) discard;
  o_color = vec4(mix(shade(), u_cut_rim_color.rgb, cut.y * u_cut_rim_color.a), 1.0);
}
