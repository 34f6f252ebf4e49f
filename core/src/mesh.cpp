#include "fabrica/core/mesh.hpp"

#include <cmath>
#include <cstdint>
#include <limits>
#include <string>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include "fabrica/core/error.hpp"

namespace fabrica {

const char* to_string(Space space) {
  return space == Space::ras ? "RAS" : "LPS";
}

const char* to_string(SpaceSource source) {
  switch (source) {
    case SpaceSource::file_tag:
      return "file tag";
    case SpaceSource::user_override:
      return "user override";
    case SpaceSource::default_assumed:
      break;
  }
  return "default (no tag in file)";
}

namespace {

// Whether every coordinate is finite and at most 1e15 in magnitude, and
// every face index in [0, nv): branch-free loops (the compiler vectorises
// them), so a valid mesh, nearly always the case, costs one streaming read.
bool mesh_indices_and_values_ok(const TriangleMesh& mesh) {
  if (mesh.positions.size() > std::numeric_limits<std::int32_t>::max()) return false;
  // Flat views of the coordinates (3 doubles per vertex) and indices (3 per
  // face), as the face kernels read them.
  const double* c = mesh.positions.empty() ? nullptr : mesh.positions[0].data();
  const std::size_t nc = 3 * mesh.positions.size();
  unsigned bad = 0;
  std::size_t i = 0;
#if defined(__SSE2__)
  // Two coordinates at a time: |c| not <= 1e15 (NaN included).
  const __m128d sign = _mm_set1_pd(-0.0), limit = _mm_set1_pd(1e15);
  __m128d any = _mm_setzero_pd();
  for (; i + 2 <= nc; i += 2)
    any = _mm_or_pd(any, _mm_cmpnle_pd(_mm_andnot_pd(sign, _mm_loadu_pd(c + i)), limit));
  bad |= unsigned(_mm_movemask_pd(any));
#endif
  for (; i < nc; ++i) bad |= unsigned(!(std::abs(c[i]) <= 1e15));  // NaN too
  const auto nv = static_cast<std::uint32_t>(mesh.positions.size());
  const std::int32_t* idx = mesh.faces.empty() ? nullptr : mesh.faces[0].data();
  const std::size_t ni = 3 * mesh.faces.size();
  for (std::size_t i = 0; i < ni; ++i) bad |= unsigned(static_cast<std::uint32_t>(idx[i]) >= nv);
  return bad == 0;
}

}  // namespace

void check_mesh_indices_and_values(const TriangleMesh& mesh, const std::string& what) {
  if (mesh_indices_and_values_ok(mesh)) return;
  // Something is wrong: find the first offender for the message.
  const auto nv = static_cast<std::int64_t>(mesh.positions.size());
  for (std::size_t i = 0; i < mesh.positions.size(); ++i)
    if (!mesh.positions[i].allFinite())
      throw InputError(
          what + ": vertex " + std::to_string(i) +
          " has a coordinate that is not a finite number (NaN or infinity); fix or remove it");
    else if (mesh.positions[i].cwiseAbs().maxCoeff() > 1e15)  // areas, normals would overflow
      throw InputError(what + ": vertex " + std::to_string(i) +
                       " has a coordinate beyond 1e15 (mm); rescale the mesh");
  for (std::size_t f = 0; f < mesh.faces.size(); ++f)
    for (int k = 0; k < 3; ++k)
      if (mesh.faces[f][k] < 0 || mesh.faces[f][k] >= nv)
        throw InputError(what + ": face " + std::to_string(f) + " refers to vertex " +
                         std::to_string(mesh.faces[f][k]) + ", but the mesh has only " +
                         std::to_string(nv) + " vertices");
}

BoundingBox bounding_box(const std::vector<Vec3>& positions) {
  BoundingBox box;
  if (positions.empty()) return box;
  box.min = box.max = positions.front();
  for (const Vec3& p : positions) {
    box.min = box.min.cwiseMin(p);
    box.max = box.max.cwiseMax(p);
  }
  return box;
}

}  // namespace fabrica
