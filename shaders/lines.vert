// Lines as screen-space quads (a triangle strip per polyline with miter
// joins): width in output pixels, independent of glLineWidth limits.
// a_params = (side +-1, strength, arc length from the start in mm, total
// length in mm; 0 = closed, no taper).
layout(location = 0) in vec3 a_position;
layout(location = 1) in vec3 a_prev;
layout(location = 2) in vec3 a_next;
layout(location = 3) in vec4 a_params;
uniform mat4 u_model_view;
uniform mat4 u_projection;
uniform vec2 u_image_size;       // whole image, pixels
uniform float u_width;           // full width in pixels
uniform float u_taper;           // fraction of the length tapered at each end
uniform int u_width_by_strength;
uniform float u_px_per_mm;       // for dash lengths
uniform float u_aa_margin;       // pixels past the half width (1, or 0.5: tight quads)
out float v_across;              // signed distance from the centre line, pixels
out float v_half_width;
out float v_strength;
out float v_arc_px;
vec2 to_pixels(vec4 c) { return (c.xy / c.w * 0.5 + 0.5) * u_image_size; }
void main() {
  clip_at(a_position);
  vec4 cp = u_projection * (u_model_view * vec4(a_position, 1.0));
  vec4 ca = u_projection * (u_model_view * vec4(a_prev, 1.0));
  vec4 cb = u_projection * (u_model_view * vec4(a_next, 1.0));
  float side = a_params.x;
  v_strength = a_params.y;
  v_arc_px = a_params.z * u_px_per_mm;
  if (cp.w <= 1.0e-6 || ca.w <= 1.0e-6 || cb.w <= 1.0e-6) {  // behind the eye: drop
    gl_Position = vec4(2.0, 2.0, 2.0, 1.0);
    v_across = 0.0;
    v_half_width = 0.0;
    return;
  }
  vec2 sp = to_pixels(cp), sa = to_pixels(ca), sb = to_pixels(cb);
  vec2 d0 = sp - sa, d1 = sb - sp;
  if (dot(d0, d0) < 1.0e-8) d0 = d1;
  if (dot(d1, d1) < 1.0e-8) d1 = d0;
  if (dot(d0, d0) < 1.0e-8) { d0 = vec2(1.0, 0.0); d1 = d0; }
  d0 = normalize(d0);
  d1 = normalize(d1);
  vec2 n0 = vec2(-d0.y, d0.x), n1 = vec2(-d1.y, d1.x);
  vec2 m = n0 + n1;
  m = dot(m, m) < 1.0e-6 ? n1 : normalize(m);
  float taper = 1.0;
  if (a_params.w > 0.0 && u_taper > 0.0) {
    float t = a_params.z / a_params.w;
    taper = mix(0.3, 1.0, smoothstep(0.0, u_taper, t) * smoothstep(0.0, u_taper, 1.0 - t));
  }
  float strength_width = u_width_by_strength == 1 ? mix(0.4, 1.0, v_strength) : 1.0;
  float h = 0.5 * u_width * taper * strength_width;
  float extent = h + u_aa_margin;  // margin for the anti-aliased edge
  float len = extent / max(dot(m, n1), 0.5);  // miter, limited to twice the width
  vec2 q = sp + m * len * side;
  v_across = side * extent;
  v_half_width = h;
  vec2 ndc = q / u_image_size * 2.0 - 1.0;
  gl_Position = to_tile(vec4(ndc * cp.w, cp.z, cp.w));
}
