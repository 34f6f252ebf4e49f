// fabrica-study: the per-participant plan (docs/study.md "The plan").
//
// Randomness is our own, documented, so that a plan is the same bytes on
// every machine and library version: SplitMix64 (Steele, Lea & Flood 2014)
// seeds xoshiro256** (Blackman & Vigna 2018); integers below n by
// rejection, doubles from the top 53 bits; shuffles are Fisher-Yates from
// the last element down. std:: distributions are never used (their output
// differs between standard libraries).
#pragma once

#include <nlohmann/json.hpp>

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "fabrica/core/camera.hpp"
#include "fabrica/core/mesh.hpp"
#include "study.hpp"

namespace fabrica::study {

std::uint64_t splitmix64(std::uint64_t& state);
/// FNV-1a, 64 bit, of the bytes of s.
std::uint64_t fnv1a64(const std::string& s);

class Rng {
 public:
  explicit Rng(std::uint64_t seed);
  std::uint64_t next();
  /// Uniform integer in [0, n), n >= 1 (rejection sampling, no modulo bias).
  std::uint64_t below(std::uint64_t n);
  /// Uniform double in [0, 1).
  double uniform();
  template <class T>
  void shuffle(std::vector<T>& v) {
    for (std::size_t i = v.size(); i > 1; --i) std::swap(v[i - 1], v[below(i)]);
  }

 private:
  std::array<std::uint64_t, 4> s_;
};

/// The participant's seed: splitmix64 of (study seed XOR fnv1a64(id)).
std::uint64_t participant_seed(std::uint64_t study_seed, const std::string& participant);

/// Williams' balanced Latin square for k conditions: k rows for even k,
/// 2k rows (each row and its reverse) for odd k; every condition appears
/// once per position over the rows, and (even k) each ordered pair of
/// neighbours once. Row r of the square.
std::vector<int> latin_square_row(int k, int row);
int latin_square_rows(int k);
/// The participant's row: the number formed by the id's trailing digits
/// (P07 -> 7), else fnv1a64(id); modulo the number of rows.
int participant_row(const std::string& participant, int rows);

/// A model as loaded for the study: the mesh prepared as `fabrica lines`
/// and `render` prepare it (oriented outward); for a scene, its focus
/// structures merged (all structures when it has no focus): gauges sit on
/// what is drawn solid. A preset view is fitted to `box`, every structure.
struct ModelGeometry {
  TriangleMesh mesh;
  std::vector<Vec3> normals;  ///< unit vertex normals
  BoundingBox box;            ///< of every structure
};
ModelGeometry load_model(const Model& model);

/// The camera of a stimulus: the view's camera file, or the preset view
/// fitted to the model as `fabrica render --view` fits it; at the study size.
Camera stimulus_camera(const Study& study, const Model& model, const View& view,
                       const ModelGeometry& geometry);

struct GaugePoint {
  Vec2 pixel;   ///< image pixels, x right, y down (a pixel centre)
  Vec3 normal;  ///< unit, view space: x right, y up, z towards the viewer
};

/// n visible surface points of the mesh seen by `camera`: pixels drawn at
/// random where the CPU depth buffer is covered in a 7x7 window (not at a
/// silhouette), the nearest triangle under the pixel centre (depth test),
/// the perspective-correct interpolated vertex normal, facing the viewer.
/// Points are kept at least `min_spacing` pixels apart where possible.
std::vector<GaugePoint> sample_gauge_points(const ModelGeometry& geometry, const Camera& camera,
                                            int n, Rng& rng);

/// The plan of one participant (deterministic: same study and id, same JSON).
nlohmann::json make_plan(const Study& study, const std::string& participant);

/// The stimulus id of a technique, model and view: "TECHNIQUE.MODEL.VIEW".
std::string stimulus_id(const std::string& technique, const std::string& model,
                        const std::string& view);

}  // namespace fabrica::study
