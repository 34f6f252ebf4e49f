// The cutaway's distance field by jump flooding (Rong & Tan 2006;
// docs/algorithms.md §15): every pixel ends with (close to) the nearest
// focus pixel. cutaway_seed.frag seeds the focus pixels; each pass looks at
// the 3x3 pixels u_step apart and keeps the nearest seed they hold (ties to
// the first in a fixed order, so the result is deterministic). The passes
// run only where no focus is drawn (cutaway_far.vert).
uniform sampler2D u_input;  // the seeds so far (x < 0: none)
uniform int u_step;
uniform vec2 u_size;  // the tile's render size (the target may be larger)
layout(location = 0) out vec2 o_seed;
void main() {
  ivec2 p = ivec2(gl_FragCoord.xy);
  vec2 best = vec2(-1.0);
  float best_d = 3.0e38;
  for (int j = -1; j <= 1; ++j) {
    for (int i = -1; i <= 1; ++i) {
      ivec2 q = p + ivec2(i, j) * u_step;
      if (q.x < 0 || q.y < 0 || float(q.x) >= u_size.x || float(q.y) >= u_size.y) continue;
      vec2 s = texelFetch(u_input, q, 0).xy;
      if (s.x < 0.0) continue;
      vec2 d = s - vec2(p);
      float dd = dot(d, d);
      if (dd < best_d) {
        best_d = dd;
        best = s;
      }
    }
  }
  o_seed = best;
}
