// Surface LIC noise (docs/algorithms.md §14): solid value noise at p (in
// noise cells), a hashed value per integer lattice point, smoothstep-
// trilinear between them. render/src/lic.cpp (lic_noise) is the same
// function on the CPU: same hash, same interpolation order.
uint lic_hash(ivec3 c) {
  uint h = (uint(c.x) * 0x8da6b343u) ^ (uint(c.y) * 0xd8163841u) ^ (uint(c.z) * 0xcb1ab31fu);
  h ^= h >> 16u;
  h *= 0x7feb352du;
  h ^= h >> 15u;
  h *= 0x846ca68bu;
  h ^= h >> 16u;
  return h;
}
float lic_lattice(ivec3 c) { return float(lic_hash(c) >> 8u) * (1.0 / 16777216.0); }
float lic_noise(vec3 p) {
  vec3 f = floor(p);
  ivec3 i = ivec3(f);
  vec3 t = p - f;
  t = t * t * (3.0 - 2.0 * t);
  float c00 = mix(lic_lattice(i), lic_lattice(i + ivec3(1, 0, 0)), t.x);
  float c10 = mix(lic_lattice(i + ivec3(0, 1, 0)), lic_lattice(i + ivec3(1, 1, 0)), t.x);
  float c01 = mix(lic_lattice(i + ivec3(0, 0, 1)), lic_lattice(i + ivec3(1, 0, 1)), t.x);
  float c11 = mix(lic_lattice(i + ivec3(0, 1, 1)), lic_lattice(i + ivec3(1, 1, 1)), t.x);
  return mix(mix(c00, c10, t.y), mix(c01, c11, t.y), t.z);
}
