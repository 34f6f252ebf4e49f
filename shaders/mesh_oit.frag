// Weighted blended order-independent transparency (McGuire & Bavoil 2013,
// weight of their eq. 10), in one pass with additive blending only (GL 3.3
// has no per-buffer blend functions): target 0 accumulates the weighted
// premultiplied colour and weight, target 1 accumulates -log(1 - alpha), so
// the composite's revealage prod(1 - alpha_i) = exp(-sum).
layout(location = 0) out vec4 o_accum;
layout(location = 1) out vec4 o_reveal;
// Target 2 where bound (the renderer's half-resolution ghosts, blended by
// GL_MIN): the fragment's depth, so the ghosts' nearest depth needs no pass
// of its own.
layout(location = 2) out vec4 o_depth;
// The weight of eq. 10 with (1 - z)^3 as two products (not pow: cheaper on
// a software rasteriser).
float oit_weight(float a) {
  float y = 1.0 - gl_FragCoord.z;
  return a * clamp(3.0e3 * (y * y * y), 1.0e-2, 3.0e3);
}
#ifdef NO_CUT
// A ghosted structure no cutaway touches: its opacity (0 < a < 1) is the
// same on every fragment, so -log(1 - a) comes in as u_reveal and nothing
// is discarded.
uniform float u_reveal;
void main() {
  float a = clamp(u_color.a, 0.0, 0.999);
  o_accum = vec4(shade() * a, a) * oit_weight(a);
  o_reveal = vec4(u_reveal, 0.0, 0.0, 0.0);
  o_depth = vec4(gl_FragCoord.z);
}
#else
// The cutaway (cutaway.glsl) scales the opacity; an opaque structure comes
// here only for the fade of its cut (the opaque pass dropped those pixels).
void main() {
  vec2 cut = cutaway();
  if (u_color.a >= 0.999 && cut.x >= 1.0) discard;
  float a = clamp(mix(u_color.a * cut.x, 1.0, cut.y * u_cut_rim_color.a), 0.0, 0.999);
  if (a <= 0.0) discard;
  o_accum = vec4(mix(shade(), u_cut_rim_color.rgb, cut.y) * a, a) * oit_weight(a);
  o_reveal = vec4(-log(1.0 - a), 0.0, 0.0, 0.0);
  o_depth = vec4(gl_FragCoord.z);
}
#endif
