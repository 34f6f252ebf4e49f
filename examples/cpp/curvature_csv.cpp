// Principal curvatures of every vertex of a mesh, as CSV:
//   curvature_csv MESH OUT.csv   ->  vertex,k1,k2 (|k1| >= |k2|, 1/mesh unit)
#include <fabrica/core/atomic_file.hpp>
#include <fabrica/core/error.hpp>
#include <fabrica/core/surface.hpp>
#include <fabrica/io/mesh_io.hpp>

#include <cstdio>
#include <ostream>

int main(int argc, char** argv) try {
  if (argc != 3) return std::fprintf(stderr, "usage: %s MESH OUT.csv\n", argv[0]), 2;
  const fabrica::Surface surface(fabrica::io::read_mesh(argv[1]).mesh);
  const fabrica::PrincipalCurvatures& curvature = surface.curvature();

  // Written to a temporary file and renamed, so OUT.csv is whole or absent.
  fabrica::write_file_atomically(argv[2], [&](std::ostream& out) {
    out.precision(17);
    out << "vertex,k1,k2\n";
    for (std::size_t v = 0; v < surface.vertex_count(); ++v)
      out << v << ',' << curvature.k1[v] << ',' << curvature.k2[v] << '\n';
  });
  std::printf("%zu vertices -> %s\n", surface.vertex_count(), argv[2]);
  return 0;
} catch (const fabrica::Error& e) {  // one line naming the file; exit code by kind
  std::fprintf(stderr, "%s\n", e.what());
  return e.exit_code();
}
