// Shared by every vertex shader: maps clip coordinates of the whole image to
// those of the tile being rendered (tiled export of images larger than the
// GL framebuffer limit). u_tile = (S/T, (S - 2 O)/T - 1) per axis, where S is
// the image size, T the tile size and O the tile origin, in pixels.
uniform vec4 u_tile;
vec4 to_tile(vec4 clip) { return vec4(clip.xy * u_tile.xy + clip.w * u_tile.zw, clip.zw); }
// The context's clipping plane (render::ClipPlane, issue 18): a model-space
// position is kept where dot(u_clip.xyz, p) + u_clip.w >= 0. Takes effect
// only while GL_CLIP_DISTANCE0 is enabled (the renderer enables it for
// context structures of a scene with a clip).
uniform vec4 u_clip;
void clip_at(vec3 p) { gl_ClipDistance[0] = dot(u_clip.xyz, p) + u_clip.w; }
