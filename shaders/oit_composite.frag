// Resolves weighted blended OIT into a premultiplied colour to blend
// (ONE, ONE_MINUS_SRC_ALPHA) over the opaque image.
uniform sampler2D u_accum;
uniform sampler2D u_reveal;
layout(location = 0) out vec4 o_color;
void main() {
#ifdef HALF_RESOLUTION
  // Accumulated at half resolution: half pixel i covers pixels 2i and
  // 2i + 1, its centre at 2i + 1; both sums are interpolated linearly (the
  // average and the revealage follow from the interpolated sums).
  vec2 uv = gl_FragCoord.xy * 0.5 / vec2(textureSize(u_accum, 0));
  vec4 acc = texture(u_accum, uv);
  float coverage = 1.0 - exp(-texture(u_reveal, uv).r);
#else
  ivec2 p = ivec2(gl_FragCoord.xy);
  vec4 acc = texelFetch(u_accum, p, 0);
  float coverage = 1.0 - exp(-texelFetch(u_reveal, p, 0).r);
#endif
  if (coverage <= 1.0e-4) discard;
  vec3 average = acc.rgb / max(acc.a, 1.0e-6);
  o_color = vec4(average * coverage, coverage);
}
