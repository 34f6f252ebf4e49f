// Mesh (numpy vertices/faces viewing the C++ storage), reading and writing,
// Surface with its per-vertex geometry, Camera and the anatomical views.
#include <nlohmann/json.hpp>

#include "common.hpp"
#include "fabrica/core/error.hpp"
#include "fabrica/core/mesh_arrays.hpp"
#include "fabrica/io/mesh_io.hpp"
#include "fabrica/io/prepare.hpp"

namespace fabrica::python {

namespace {

using MeshPtr = std::shared_ptr<TriangleMesh>;

Space parse_space_name(const std::string& name) {
  if (name == "lps" || name == "LPS") return Space::lps;
  if (name == "ras" || name == "RAS") return Space::ras;
  throw InputError("space: use lps or ras (got \"" + name + "\")");
}

std::optional<Space> optional_space(const std::optional<std::string>& name) {
  if (!name) return std::nullopt;
  return parse_space_name(*name);
}

MeshPtr mesh_from_numpy(const py::array& vertices, const py::array& faces,
                        const std::string& space) {
  const auto V = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(vertices);
  const auto F =
      py::array_t<std::int64_t, py::array::c_style | py::array::forcecast>::ensure(faces);
  if (!V || !F) throw InputError("Mesh: vertices and faces must be numeric arrays");
  if (V.ndim() != 2 || F.ndim() != 2)
    throw InputError("Mesh: vertices must be an (n, 3) array and faces an (m, 3) array");
  const Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>> Vm(
      V.data(), V.shape(0), V.shape(1));
  const Eigen::Map<
      const Eigen::Matrix<std::int64_t, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>
      Fm(F.data(), F.shape(0), F.shape(1));
  auto mesh =
      std::make_shared<TriangleMesh>(mesh_from_arrays(Vm, Fm, parse_space_name(space), "Mesh"));
  mesh->space_source = SpaceSource::user_override;
  return mesh;
}

std::vector<double> to_vector(const Vec3& v) {
  return {v.x(), v.y(), v.z()};
}
Vec3 to_vec3(const std::vector<double>& v, const char* what) {
  if (v.size() != 3) throw InputError(std::string("Camera.") + what + ": expected three numbers");
  return {v[0], v[1], v[2]};
}

}  // namespace

const TriangleMesh& as_mesh(const py::object& obj) {
  if (py::isinstance<PySurface>(obj)) return obj.cast<const PySurface&>().surface->mesh();
  if (py::isinstance<TriangleMesh>(obj)) return obj.cast<const TriangleMesh&>();
  throw py::type_error("expected a fabrica.Mesh or fabrica.Surface");
}

std::shared_ptr<PySurface> as_surface(const py::object& obj) {
  if (py::isinstance<PySurface>(obj)) return obj.cast<std::shared_ptr<PySurface>>();
  const TriangleMesh& mesh = as_mesh(obj);
  auto out = std::make_shared<PySurface>();
  py::gil_scoped_release release;
  PreparedMesh prepared = prepare_mesh(mesh, PrepareOptions{}, "mesh");
  out->notes = prepared.messages();
  out->surface = std::make_shared<const Surface>(to_surface(std::move(prepared)));
  return out;
}

void bind_mesh(py::module_& m) {
  py::class_<TriangleMesh, MeshPtr>(m, "Mesh",
                                    "An indexed triangle mesh: vertices (n, 3) float64 in mm, "
                                    "faces (m, 3) int32, and its anatomical space (lps or ras).")
      .def(py::init(&mesh_from_numpy), py::arg("vertices"), py::arg("faces"),
           py::arg("space") = "lps",
           "A mesh from an (n, 3) array of vertex positions and an (m, 3) array of vertex "
           "indices (copied once into the mesh). Raises InputError (a ValueError) for bad "
           "shapes, out-of-range indices or non-finite coordinates.")
      .def_property_readonly(
          "vertices",
          [](py::object self) {
            const auto& mesh = self.cast<const TriangleMesh&>();
            return view_array(mesh.positions.empty() ? nullptr : mesh.positions.front().data(),
                              mesh.positions.size(), 3, self);
          },
          "(n, 3) float64, read-only view of the mesh's own storage (no copy)")
      .def_property_readonly(
          "faces",
          [](py::object self) {
            const auto& mesh = self.cast<const TriangleMesh&>();
            return view_array(mesh.faces.empty() ? nullptr : mesh.faces.front().data(),
                              mesh.faces.size(), 3, self);
          },
          "(m, 3) int32, read-only view of the mesh's own storage (no copy)")
      .def_property_readonly(
          "space", [](const TriangleMesh& mesh) { return std::string(to_string(mesh.space)); })
      .def_property_readonly("vertex_count", &TriangleMesh::vertex_count)
      .def_property_readonly("face_count", &TriangleMesh::face_count)
      .def(
          "bounding_box",
          [](const TriangleMesh& mesh) {
            const BoundingBox b = bounding_box(mesh.positions);
            return py::make_tuple(to_vector(b.min), to_vector(b.max));
          },
          "(min, max) corners of the axis-aligned bounding box")
      .def("__repr__", [](const TriangleMesh& mesh) {
        return "<fabrica.Mesh " + std::to_string(mesh.vertex_count()) + " vertices, " +
               std::to_string(mesh.face_count()) + " faces, " + to_string(mesh.space) + ">";
      });

  m.def(
      "read_mesh",
      [](const std::string& path, std::optional<std::string> space) {
        io::ReadOptions options;
        options.space = optional_space(space);
        py::gil_scoped_release release;
        return std::make_shared<TriangleMesh>(io::read_mesh(path, options).mesh);
      },
      py::arg("path"), py::arg("space") = py::none(),
      "Reads a mesh file (OBJ, PLY, STL, OFF, VTP, VTK, GIfTI, MNI .obj, FreeSurfer) as stored: "
      "vertex i is the file's vertex i. `space` ('lps' or 'ras') overrides the file's tag. "
      "Raises InputError (ValueError) naming the file.");
  m.def(
      "write_mesh",
      [](const TriangleMesh& mesh, const std::string& path, bool binary) {
        io::WriteOptions options;
        options.binary = binary;
        py::gil_scoped_release release;
        io::write_mesh(mesh, path, options);
      },
      py::arg("mesh"), py::arg("path"), py::arg("binary") = true,
      "Writes a mesh by extension (.obj .ply .off .stl), atomically. Raises OutputError "
      "(OSError) when the file cannot be written.");

  py::class_<PySurface, std::shared_ptr<PySurface>>(
      m, "Surface",
      "A mesh with its differential geometry, prepared as the CLI prepares it (welded, "
      "oriented consistently and outward unless orient=False).")
      .def(py::init(
               [](const TriangleMesh& mesh, bool orient, const std::string& normals, int smooth) {
                 SurfaceOptions options;
                 if (normals == "area")
                   options.normal_weighting = NormalWeighting::area;
                 else if (normals == "angle")
                   options.normal_weighting = NormalWeighting::angle;
                 else if (normals != "max")
                   throw InputError("normals: use max, area or angle (got \"" + normals + "\")");
                 if (smooth < 0 || smooth > 100) throw InputError("smooth: must be in [0, 100]");
                 options.curvature_smoothing_passes = options.derivative_smoothing_passes = smooth;
                 auto out = std::make_shared<PySurface>();
                 py::gil_scoped_release release;
                 PrepareOptions prepare;
                 prepare.orient = orient;
                 PreparedMesh prepared = prepare_mesh(mesh, prepare, "mesh");
                 out->notes = prepared.messages();
                 out->surface =
                     std::make_shared<const Surface>(to_surface(std::move(prepared), options));
                 return out;
               }),
           py::arg("mesh"), py::arg("orient") = true, py::arg("normals") = "max",
           py::arg("smooth") = 0)
      .def_property_readonly(
          "mesh",
          [](const PySurface& s) { return std::make_shared<TriangleMesh>(s.surface->mesh()); },
          "The prepared mesh (a copy)")
      .def_property_readonly(
          "notes", [](const PySurface& s) { return s.notes; },
          "What the preparation changed, one line each")
      .def_property_readonly("vertex_count",
                             [](const PySurface& s) { return s.surface->vertex_count(); })
      .def_property_readonly("face_count",
                             [](const PySurface& s) { return s.surface->face_count(); })
      .def_property_readonly(
          "feature_size",
          [](const PySurface& s) {
            py::gil_scoped_release release;
            return s.surface->feature_size();
          },
          "rtsc's feature size in mm (the scale of the line thresholds)")
      .def(
          "geometry",
          [](py::object self) {
            const Surface& s = *self.cast<const PySurface&>().surface;
            {
              py::gil_scoped_release release;
              s.precompute();
            }
            const std::size_t n = s.vertex_count();
            const auto& curv = s.curvature();
            const auto& der = s.curvature_derivatives();
            py::dict g;
            g["position"] = view_array(s.positions().front().data(), n, 3, self);
            g["normal"] = view_array(s.vertex_normals().front().data(), n, 3, self);
            g["area"] = view_array(s.vertex_areas().data(), n, 1, self);
            g["k1"] = view_array(curv.k1.data(), n, 1, self);
            g["k2"] = view_array(curv.k2.data(), n, 1, self);
            g["e1"] = view_array(curv.e1.front().data(), n, 3, self);
            g["e2"] = view_array(curv.e2.front().data(), n, 3, self);
            std::vector<double> H(n), K(n), D(4 * n);
            std::vector<std::uint8_t> valid(n);
            for (std::size_t v = 0; v < n; ++v) {
              H[v] = curv.mean(v);
              K[v] = curv.gaussian(v);
              D[4 * v] = der.a[v], D[4 * v + 1] = der.b[v], D[4 * v + 2] = der.c[v],
                    D[4 * v + 3] = der.d[v];
              valid[v] = curv.valid[v] && der.valid[v];
            }
            const auto ns = static_cast<py::ssize_t>(n);
            g["H"] = own_array(std::move(H), {ns});
            g["K"] = own_array(std::move(K), {ns});
            g["derivatives"] = own_array(std::move(D), {ns, 4});
            g["valid"] = own_array(std::move(valid), {ns}).attr("astype")("bool");
            return g;
          },
          "Per-vertex geometry as numpy arrays: position, normal (n,3); area (mixed Voronoi); "
          "k1, k2 (|k1| >= |k2|, 1/mm); e1, e2 (n,3) principal directions; H, K (mean, "
          "Gaussian); derivatives (n,4) the curvature-derivative tensor a, b, c, d (1/mm^2); "
          "valid (bool). position..e2 are read-only views into the Surface (no copy).")
      .def("__repr__", [](const PySurface& s) {
        return "<fabrica.Surface " + std::to_string(s.surface->vertex_count()) + " vertices, " +
               std::to_string(s.surface->face_count()) + " faces>";
      });

  py::class_<Camera>(m, "Camera",
                     "A pinhole (or orthographic) camera and its image size; the JSON format of "
                     "`fabrica --camera`.")
      .def(py::init<>())
      .def_property(
          "eye", [](const Camera& c) { return to_vector(c.eye); },
          [](Camera& c, const std::vector<double>& v) { c.eye = to_vec3(v, "eye"); })
      .def_property(
          "center", [](const Camera& c) { return to_vector(c.center); },
          [](Camera& c, const std::vector<double>& v) { c.center = to_vec3(v, "center"); })
      .def_property(
          "up", [](const Camera& c) { return to_vector(c.up); },
          [](Camera& c, const std::vector<double>& v) { c.up = to_vec3(v, "up"); })
      .def_readwrite("fov", &Camera::fov_deg, "vertical field of view in degrees")
      .def_readwrite("width", &Camera::width)
      .def_readwrite("height", &Camera::height)
      .def_property(
          "projection",
          [](const Camera& c) {
            return std::string(c.projection == Projection::perspective ? "perspective"
                                                                       : "orthographic");
          },
          [](Camera& c, const std::string& p) {
            if (p == "perspective")
              c.projection = Projection::perspective;
            else if (p == "orthographic")
              c.projection = Projection::orthographic;
            else
              throw InputError("Camera.projection: use perspective or orthographic");
          })
      .def_static(
          "view",
          [](const py::object& mesh, const std::string& name, int width, int height, double fov) {
            const auto view = parse_anatomical_view(name);
            if (!view)
              throw InputError("view: unknown view \"" + name +
                               "\" (anterior, posterior, left, right, superior, inferior)");
            const TriangleMesh& m = as_mesh(mesh);
            Camera c =
                anatomical_camera(*view, bounding_box(m.positions), m.space, width, height, fov);
            validate_camera(c, "view " + name);
            return c;
          },
          py::arg("mesh"), py::arg("name") = "anterior", py::arg("width") = 1024,
          py::arg("height") = 1024, py::arg("fov") = 30.0,
          "The anatomical view (anterior, posterior, left, right, superior, inferior) of a Mesh "
          "or Surface in its space, as `--view NAME`.")
      .def_static(
          "from_json",
          [](const std::string& text) {
            nlohmann::json j;
            try {
              j = nlohmann::json::parse(text);
            } catch (const nlohmann::json::exception& e) {
              throw InputError(std::string("camera: not valid JSON (") + e.what() + ")");
            }
            return camera_from_json(j, "camera");
          },
          py::arg("text"), "A camera from JSON text (the --camera format)")
      .def_static(
          "read", [](const std::string& path) { return read_camera(path); }, py::arg("path"),
          "Reads a camera JSON file (or a .seg file's header)")
      .def("to_json", [](const Camera& c) { return camera_to_json(c).dump(1); })
      .def(
          "write", [](const Camera& c, const std::string& path) { write_camera(c, path); },
          py::arg("path"))
      .def(
          "project",
          [](const Camera& c,
             const py::array_t<double, py::array::c_style | py::array::forcecast>& p) {
            if (p.ndim() != 2 || p.shape(1) != 3)
              throw InputError("Camera.project: expected a (k, 3) array of points");
            const auto k = static_cast<std::size_t>(p.shape(0));
            std::vector<double> pixels(2 * k), depth(k);
            for (std::size_t i = 0; i < k; ++i) {
              const auto q = project(c, Vec3(p.at(i, 0), p.at(i, 1), p.at(i, 2)));
              pixels[2 * i] = q.pixel.x(), pixels[2 * i + 1] = q.pixel.y(), depth[i] = q.depth;
            }
            const auto ks = static_cast<py::ssize_t>(k);
            return py::make_tuple(own_array(std::move(pixels), {ks, 2}),
                                  own_array(std::move(depth), {ks}));
          },
          py::arg("points"),
          "(pixels (k,2), depth (k,)): image positions (x right, y down) and distances along "
          "the view direction")
      .def("__repr__",
           [](const Camera& c) { return "<fabrica.Camera " + camera_to_json(c).dump() + ">"; });
}

}  // namespace fabrica::python
