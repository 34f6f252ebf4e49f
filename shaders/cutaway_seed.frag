// The cutaway's seeds (docs/algorithms.md §15), drawn with the focus
// structures: each focus pixel of the picture (not of a tile's margin, so
// tiling changes nothing) is its own nearest focus pixel, written into both
// jump-flooding targets; the other pixels keep the clear value -1 (none).
uniform vec4 u_picture;  // the picture's pixels in the tile: (x0, y0, x1, y1), [x0, x1) x [y0, y1)
layout(location = 0) out vec2 o_seed0;
layout(location = 1) out vec2 o_seed1;
void main() {
  vec2 c = gl_FragCoord.xy;
  bool inside = c.x >= u_picture.x && c.y >= u_picture.y && c.x < u_picture.z && c.y < u_picture.w;
  vec2 seed = inside ? floor(c) : vec2(-1.0);
  o_seed0 = seed;
  o_seed1 = seed;
}
