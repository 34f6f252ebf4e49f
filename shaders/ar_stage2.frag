// Hybrid apparent ridges, image-space stage (seed 000, listing A.2, as
// reconstructed in docs/algorithms.md §6.4): the direction-adaptive Laplacian-like
// filter v = (8 + 8 lambda) q4 - sum_n w_n q_n with
// w_n = 1 + 2 lambda cos^2(phi_n - theta), theta = t1 quantised to 0, 45, 90
// or 135 degrees; a line where v > threshold, grey 1 - v (fade) or black.
uniform sampler2D u_data;
uniform float u_lambda;
uniform float u_threshold;
uniform int u_fade;
uniform int u_sign_free;
uniform vec4 u_line_color;
layout(location = 0) out vec4 o_color;
void main() {
  ivec2 p = ivec2(gl_FragCoord.xy);
  vec4 centre = texelFetch(u_data, p, 0);
  if (centre.a < 0.5) discard;  // background or occluder
  // q >= 0 and (for lambda >= -1/2) w_n >= 0, so v <= (8 + 8 lambda) q4:
  // pixels that cannot pass skip the rest.
  float v = (8.0 + 8.0 * u_lambda) * centre.r;
  if (u_lambda >= -0.5 && v <= u_threshold) discard;
  vec2 t1 = 2.0 * (centre.gb - 0.5);
  if (t1 == vec2(0.0)) discard;  // seed: undefined direction = background
  if (u_sign_free == 1) {
    float phi = 0.5 * atan(t1.y, t1.x);
    t1 = vec2(cos(phi), sin(phi));
  }
  const float b = 0.92387953251080;  // cos(pi/8)
  const float a = 0.70710678118655;
  ivec2 d;
  if (abs(dot(t1, vec2(1.0, 0.0))) > b)
    d = ivec2(1, 0);
  else if (abs(dot(t1, vec2(a, a))) > b)
    d = ivec2(1, 1);
  else if (abs(dot(t1, vec2(0.0, 1.0))) > b)
    d = ivec2(0, 1);
  else
    d = ivec2(-1, 1);
  // The weights in closed form: cos^2 is 1 along d, 0 across it and 1/2 on
  // the two 45-degree pairs, so sum_n w_n q_n = sum_n q_n + 2 lambda C with
  // C the pair along d plus half the two pairs at 45 degrees. The pass is
  // scissored to one pixel inside the target, so every neighbour exists.
#define Q(dx, dy) texelFetch(u_data, p + ivec2(dx, dy), 0).r
  float h = Q(-1, 0) + Q(1, 0), vert = Q(0, 1) + Q(0, -1);    // along x, along y
  float diag = Q(1, 1) + Q(-1, -1), anti = Q(-1, 1) + Q(1, -1);  // along (1,1), (-1,1)
#undef Q
  float C = d.y == 0 ? h + 0.5 * (diag + anti)
            : d.x == 0 ? vert + 0.5 * (diag + anti)
            : d.x == d.y ? diag + 0.5 * (h + vert)
                         : anti + 0.5 * (h + vert);
  v -= (h + vert + diag + anti) + 2.0 * u_lambda * C;
  if (v <= u_threshold) discard;
  float ink = u_fade == 1 ? min(v, 1.0) : 1.0;
  float alpha = ink * u_line_color.a;
  o_color = vec4(u_line_color.rgb * alpha, alpha);
}
