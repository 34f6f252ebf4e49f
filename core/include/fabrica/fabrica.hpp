// The umbrella header (issue 16): `#include <fabrica/fabrica.hpp>` gives the
// one-call API of every component this build has (docs/api.md):
//   core      TriangleMesh (+ from/to arrays), Surface, Camera, errors
//   io        read_mesh/write_mesh, prepare_mesh
//   lines     draw_lines, LineDrawer, the SVG/PDF/JSON/.seg writers
//   hatching  draw_hatching and its SVG writer
//   render    load_scene, render_scene, write_png (headless OpenGL)
// A component that is not built (or not linked) is simply left out.
#pragma once

#include "fabrica/core/camera.hpp"
#include "fabrica/core/error.hpp"
#include "fabrica/core/mesh.hpp"
#include "fabrica/core/mesh_arrays.hpp"
#include "fabrica/core/surface.hpp"

#if __has_include("fabrica/io/prepare.hpp")
#include "fabrica/io/mesh_io.hpp"
#include "fabrica/io/prepare.hpp"
#endif
#if __has_include("fabrica/lines/draw.hpp")
#include "fabrica/lines/draw.hpp"
#include "fabrica/lines/seg_io.hpp"
#include "fabrica/lines/writers.hpp"
#endif
#if __has_include("fabrica/hatching/draw.hpp")
#include "fabrica/hatching/draw.hpp"
#include "fabrica/hatching/svg_writer.hpp"
#endif
#if __has_include("fabrica/render/draw.hpp")
#include "fabrica/render/draw.hpp"
#endif
