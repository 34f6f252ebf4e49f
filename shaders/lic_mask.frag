// Surface LIC, between the stages: keeps (for a depth write) the pixels with
// a feature mask > 0, so the convolution runs on them only (the hybrid
// method's trick, renderer.cpp: a software rasteriser skips blocks that fail
// the early depth test).
uniform sampler2D u_data;
void main() {
  if (!(texelFetch(u_data, ivec2(gl_FragCoord.xy), 0).a > 0.0)) discard;
}
