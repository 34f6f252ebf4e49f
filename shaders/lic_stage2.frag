// Surface LIC, stage 2 (docs/algorithms.md §14): the line integral
// convolution of stage 1's noise along its direction field (RGBA8: the
// direction as dir * 0.5 + 0.5, decoded as 2 x - 1), from the pixel
// both ways, u_steps steps of u_step pixels each (Euler; each step takes the
// direction of the texel it lands on, its sign aligned with the previous
// one), stopping at the target's edge or where the mask is 0; Hann weights
// u_weights[i - 1] = 0.5 + 0.5 cos(pi i / (steps + 1)) (computed once on the
// CPU, lic_kernel), the centre weight 1. The mean is
// stretched around 0.5 by u_gain and clamped to [0, 1]: v. Output (blended
// by multiplication into the shaded colour) mix(1, v, strength * mask); with
// LIC_VALUE, (v, mask, 0, 1) for the tests. render/src/lic.cpp
// (lic_reference) is the same on the CPU.
uniform sampler2D u_data;
uniform int u_steps;
uniform float u_step;
uniform float u_gain;
uniform float u_strength;
uniform float u_weights[LIC_MAX_STEPS];
layout(location = 0) out vec4 o_color;
void main() {
  ivec2 size = textureSize(u_data, 0);
  vec4 c = texelFetch(u_data, ivec2(gl_FragCoord.xy), 0);
  if (!(c.a > 0.0)) discard;
  float sum = c.z, wsum = 1.0;
  for (int side = 0; side < 2; ++side) {
    vec2 p = gl_FragCoord.xy;
    vec2 d = side == 0 ? 2.0 * c.xy - 1.0 : 1.0 - 2.0 * c.xy;
    for (int i = 1; i <= u_steps; ++i) {
      p += u_step * d;
      ivec2 q = ivec2(floor(p));
      if (q.x < 0 || q.y < 0 || q.x >= size.x || q.y >= size.y) break;
      vec4 s = texelFetch(u_data, q, 0);
      if (!(s.a > 0.0)) break;
      vec2 nd = 2.0 * s.xy - 1.0;
      if (dot(nd, d) < 0.0) nd = -nd;
      d = nd;
      float w = u_weights[i - 1];
      sum += w * s.z;
      wsum += w;
    }
  }
  float v = clamp(0.5 + (sum / wsum - 0.5) * u_gain, 0.0, 1.0);
#ifdef LIC_VALUE
  o_color = vec4(v, c.a, 0.0, 1.0);
#else
  o_color = vec4(vec3(mix(1.0, v, u_strength * c.a)), 1.0);
#endif
}
