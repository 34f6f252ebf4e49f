uniform sampler2D u_data;
layout(location = 0) out vec4 o_color;
void main() {
  vec4 c = texelFetch(u_data, ivec2(gl_FragCoord.xy), 0);
  if (c.a < 0.5) discard;
  o_color = vec4(c.rgb, 1.0);
}
