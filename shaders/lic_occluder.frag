// Surface LIC, stage 1: opaque structures without LIC hide it (mask 0).
layout(location = 0) out vec4 o_data;
void main() {
  cutaway_discard();
  o_data = vec4(0.0);
}
