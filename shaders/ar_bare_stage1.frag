in vec3 v_packed;
layout(location = 0) out vec4 o_data;
void main() { o_data = vec4(v_packed, 1.0); }
