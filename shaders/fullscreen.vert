// One triangle covering the viewport (no vertex buffer: gl_VertexID 0..2), at
// depth 0 (window depth 0.5). Invariant: the hybrid method's mask and filter
// passes compare the depth one writes with the other's (GL_EQUAL).
invariant gl_Position;
void main() {
  vec2 p = vec2(float((gl_VertexID << 1) & 2), float(gl_VertexID & 2));
  gl_Position = vec4(p * 2.0 - 1.0, 0.0, 1.0);
}
