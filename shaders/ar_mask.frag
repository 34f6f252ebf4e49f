// Hybrid apparent ridges, between the two stages: keeps (for a depth write)
// the pixels where the image-stage filter can ink. With q >= 0 and weights
// >= 0 (lambda >= -1/2) the filter response is at most (8 + 8 lambda) q4, so
// a pixel can pass the threshold only if q4 > threshold / (8 + 8 lambda);
// u_min_q is that bound made slightly smaller (-1 when lambda < -1/2: every
// pixel). ar_stage2.frag repeats the exact test, so the mask only has to
// keep a superset. Drawn with the stencil test on the hybrid pixels.
uniform sampler2D u_data;
uniform float u_min_q;
void main() {
  if (texelFetch(u_data, ivec2(gl_FragCoord.xy), 0).r <= u_min_q) discard;
}
