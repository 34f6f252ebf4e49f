// The cutaway (render::Cutaway, issue 18; docs/algorithms.md §15): context
// fragments in front of the focus near its screen footprint are removed.
// cutaway_jfa.frag leaves in u_cut_seeds the nearest focus pixel of each
// pixel (x < 0: none within reach) and u_cut_depth holds the focus's front
// (nearest) window depth. u_cut = (margin, fade, rim width) in pixels of
// this picture. u_cutaway is 1 while a context structure is drawn in a
// frame with a cutaway, else 0 (and nothing is read).
uniform int u_cutaway;
uniform sampler2D u_cut_seeds;
uniform sampler2D u_cut_depth;
uniform vec3 u_cut;
uniform vec4 u_cut_rim_color;
// x: the fraction of this fragment kept (1 outside the cut, 0 inside the
// margin, a smoothstep over the fade), y: the rim's coverage (0 without rim).
vec2 cutaway() {
  if (u_cutaway == 0) return vec2(1.0, 0.0);
  ivec2 p = ivec2(gl_FragCoord.xy);
  vec2 seed = texelFetch(u_cut_seeds, p, 0).xy;
  if (seed.x < 0.0) return vec2(1.0, 0.0);
  if (gl_FragCoord.z >= texelFetch(u_cut_depth, ivec2(seed), 0).r) return vec2(1.0, 0.0);
  float d = distance(seed, vec2(p));
  float outer = u_cut.x + u_cut.y;
  float keep = d <= u_cut.x ? 0.0 : d >= outer ? 1.0 : smoothstep(u_cut.x, outer, d);
  float rim = u_cut.z > 0.0 ? clamp(0.5 * u_cut.z + 0.5 - abs(d - outer - 0.5 * u_cut.z), 0.0, 1.0)
                            : 0.0;
  return vec2(keep, keep < 1.0 ? 0.0 : rim);
}
// For the passes that write depth (opaque, depth, occluders): a context
// fragment cut at all is not there (the fade is drawn by the OIT pass).
void cutaway_discard() {
  if (cutaway().x < 1.0) discard;
}
