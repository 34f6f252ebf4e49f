// The cutaway's jump-flooding passes: one triangle covering the viewport at
// the far plane (window depth 1), so a depth test EQUAL against the focus's
// depth runs them only where no focus is drawn (a focus pixel is its own
// nearest focus pixel and keeps its seed).
void main() {
  vec2 p = vec2(float((gl_VertexID << 1) & 2), float(gl_VertexID & 2));
  gl_Position = vec4(p * 2.0 - 1.0, 1.0, 1.0);
}
