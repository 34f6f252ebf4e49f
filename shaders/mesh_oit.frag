// Weighted blended order-independent transparency (McGuire & Bavoil 2013,
// weight of their eq. 10), in one pass with additive blending only (GL 3.3
// has no per-buffer blend functions): target 0 accumulates the weighted
// premultiplied colour and weight, target 1 accumulates -log(1 - alpha), so
// the composite's revealage prod(1 - alpha_i) = exp(-sum).
layout(location = 0) out vec4 o_accum;
layout(location = 1) out vec4 o_reveal;
// The cutaway (cutaway.glsl) scales the opacity; an opaque structure comes
// here only for the fade of its cut (the opaque pass dropped those pixels).
void main() {
  vec2 cut = cutaway();
  if (u_color.a >= 0.999 && cut.x >= 1.0) discard;
  float a = clamp(mix(u_color.a * cut.x, 1.0, cut.y * u_cut_rim_color.a), 0.0, 0.999);
  if (a <= 0.0) discard;
  float z = gl_FragCoord.z;
  float w = a * clamp(3.0e3 * pow(1.0 - z, 3.0), 1.0e-2, 3.0e3);
  o_accum = vec4(mix(shade(), u_cut_rim_color.rgb, cut.y) * a, a) * w;
  o_reveal = vec4(-log(1.0 - a), 0.0, 0.0, 0.0);
}
