// Reading and writing triangle-mesh files: OBJ, PLY, STL, OFF, VTP, legacy VTK.
//
// Vertex order promise: vertex i of the returned mesh is vertex i of the file
// (STL, a triangle soup: the i-th distinct point in order of first
// appearance, after welding bit-identical coordinates). Unreferenced vertices
// are kept. Polygons with more than three sides are fan-triangulated
// (v0 v1 v2, v0 v2 v3, ...) in file order; triangle strips are unrolled with
// alternating winding and triangles with a repeated vertex are dropped.
//
// Units: coordinates are taken as millimetres and never scaled.
//
// Coordinate space: 3D Slicer tags files with `SPACE=LPS` or `SPACE=RAS`
// (STL header or `solid` line, OBJ/PLY/OFF comments). The reader only labels
// the mesh with that space (mesh.space, mesh.space_source): coordinates are
// NOT changed. ReadOptions::space overrides the tag; untagged files are LPS.
// Writers write the mesh's space as a tag so round trips keep it.
//
// Errors: every malformed input (missing, empty, truncated, wrong counts,
// non-finite coordinates, bad indices, unknown extension, no faces) throws
// fabrica::InputError whose one-line message names the file. Write failures
// throw fabrica::OutputError; outputs are written atomically.
// Formats and details: docs/formats.md.
#pragma once

#include <cstddef>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "fabrica/core/mesh.hpp"
#include "fabrica/core/types.hpp"

namespace fabrica::io {

struct ReadOptions {
  /// User override of the coordinate space (command line `--space lps|ras`);
  /// wins over a tag in the file. Coordinates are never transformed.
  std::optional<Space> space;
  /// Keep per-vertex normals stored in the file (OBJ vn matched to vertices
  /// only when unambiguous, PLY nx/ny/nz, VTP point normals, OFF NOFF) in
  /// MeshFileInfo::file_normals. Ignored otherwise (fabrica computes its own).
  bool keep_file_normals = false;
};

/// What the reader found in the file (for `fabrica info` and reports).
struct MeshFileInfo {
  std::string path;
  std::string format;  ///< "obj", "ply", "stl", "off", "vtp", "vtk"
  bool binary = false;
  std::size_t file_vertices = 0;          ///< vertex records in the file (STL: 3 per triangle)
  std::size_t file_polygons = 0;          ///< polygons / strip triangles as stored
  std::size_t triangulated_polygons = 0;  ///< polygons with more than 3 sides that were split
  std::size_t welded_vertices = 0;        ///< STL: coincident points merged
  std::optional<Space> tagged_space;      ///< SPACE= tag found in the file
  std::vector<Vec3> file_normals;  ///< only when keep_file_normals and present (one per vertex)
  std::vector<std::string> notes;  ///< harmless oddities (skipped degenerate strip triangles, ...)
};

struct LoadedMesh {
  TriangleMesh mesh;
  MeshFileInfo info;
};

/// Reads a mesh; the format is chosen by extension, case-insensitive (.obj
/// Wavefront or MNI by content, .ply .stl .off .vtp .vtk .gii .gii.gz, and
/// FreeSurfer surface names or magic bytes; docs/formats.md). Throws
/// InputError naming the file on any problem, including a file with no faces.
LoadedMesh read_mesh(const std::filesystem::path& path, const ReadOptions& options = {});

struct WriteOptions {
  /// PLY: binary little endian (default) or ascii; STL: binary (default) or
  /// ascii. OBJ and OFF are always ascii (17 significant digits: exact).
  bool binary = true;
  /// Write `SPACE=LPS|RAS` (STL header / solid line, OBJ/PLY/OFF comment).
  bool write_space_tag = true;
};

/// Writes a mesh by extension (.obj .ply .off .stl). Binary STL stores float
/// coordinates (rounded from double); PLY binary stores double coordinates.
/// Throws InputError for an unknown extension or invalid mesh, OutputError
/// when the file cannot be written (nothing half-written is left).
void write_mesh(const TriangleMesh& mesh, const std::filesystem::path& path,
                const WriteOptions& options = {});

}  // namespace fabrica::io
