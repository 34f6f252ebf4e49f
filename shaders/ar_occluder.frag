// Hybrid apparent ridges, stage 1: opaque structures that are not drawn by
// the method hide it like the background does: q = 0, t1 undefined (0.5, 0.5
// encodes the zero vector), coverage 0.
layout(location = 0) out vec4 o_data;
void main() {
  cutaway_discard();
  o_data = vec4(0.0, 0.5, 0.5, 0.0);
}
