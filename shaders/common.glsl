// Shared by every vertex shader: maps clip coordinates of the whole image to
// those of the tile being rendered (tiled export of images larger than the
// GL framebuffer limit). u_tile = (S/T, (S - 2 O)/T - 1) per axis, where S is
// the image size, T the tile size and O the tile origin, in pixels.
uniform vec4 u_tile;
vec4 to_tile(vec4 clip) { return vec4(clip.xy * u_tile.xy + clip.w * u_tile.zw, clip.zw); }
