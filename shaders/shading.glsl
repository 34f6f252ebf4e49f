// Headlight shading (light at the eye). Two-sided: |n.l|, so open meshes seen
// from inside are lit too. u_shading: 0 flat colour, 1 Lambert, 2 toon with
// u_toon_levels bands. Colour = base * (ambient + (1 - ambient) * d).
uniform vec4 u_color;  // rgb and opacity
uniform int u_shading;
uniform float u_ambient;
uniform int u_toon_levels;
uniform int u_orthographic;
in vec3 v_position;
in vec3 v_normal;
vec3 shade() {
  if (u_shading == 0) return u_color.rgb;
  vec3 n = normalize(v_normal);
  vec3 l = u_orthographic == 1 ? vec3(0.0, 0.0, 1.0) : normalize(-v_position);
  float d = abs(dot(n, l));
  if (u_shading == 2) {
    float levels = float(max(u_toon_levels, 2));
    d = min(ceil(d * levels), levels) / levels;
  }
  return u_color.rgb * (u_ambient + (1.0 - u_ambient) * d);
}
