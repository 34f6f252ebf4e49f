// Opaque mesh: premultiplied colour with alpha 1 (cut context dropped, its
// rim drawn: cutaway.glsl). NO_CUT: the program of structures no cutaway
// touches, without a discard (a software rasteriser then tests depth before
// shading and skips hidden fragments' work).
layout(location = 0) out vec4 o_color;
void main() {
#ifdef NO_CUT
  o_color = vec4(shade(), 1.0);
#else
  vec2 cut = cutaway();
  if (cut.x < 1.0) discard;
  o_color = vec4(mix(shade(), u_cut_rim_color.rgb, cut.y * u_cut_rim_color.a), 1.0);
#endif
}
