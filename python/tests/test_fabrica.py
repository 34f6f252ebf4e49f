"""The fabrica Python module gives what the CLI gives on the same mesh and
camera, raises Python exceptions with the CLI's messages, and hands out
array views that keep their owner alive."""
import gc
import json
import sys

import numpy as np
import pytest

import fabrica


# --- meshes ------------------------------------------------------------------

def test_read_mesh_arrays(liver):
    mesh = fabrica.read_mesh(str(liver))
    assert mesh.vertices.dtype == np.float64 and mesh.vertices.shape == (mesh.vertex_count, 3)
    assert mesh.faces.dtype == np.int32 and mesh.faces.shape == (mesh.face_count, 3)
    assert mesh.faces.min() >= 0 and mesh.faces.max() < mesh.vertex_count
    assert mesh.space in ("LPS", "RAS")


def test_mesh_round_trip(tmp_path, liver):
    mesh = fabrica.read_mesh(str(liver))
    copy = fabrica.Mesh(mesh.vertices, mesh.faces)
    np.testing.assert_array_equal(copy.vertices, mesh.vertices)
    np.testing.assert_array_equal(copy.faces, mesh.faces)
    fabrica.write_mesh(copy, str(tmp_path / "m.off"))
    back = fabrica.read_mesh(str(tmp_path / "m.off"))
    np.testing.assert_array_equal(back.vertices, mesh.vertices)
    np.testing.assert_array_equal(back.faces, mesh.faces)
    # Any integer dtype and layout is accepted.
    fortran = fabrica.Mesh(np.asfortranarray(mesh.vertices), mesh.faces.astype(np.int64))
    np.testing.assert_array_equal(fortran.faces, mesh.faces)


def test_views_keep_their_owner_alive(liver):
    mesh = fabrica.read_mesh(str(liver))
    before = sys.getrefcount(mesh)
    v = mesh.vertices
    assert not v.flags.writeable and not v.flags.owndata  # a view, not a copy
    assert v.base is mesh or getattr(v.base, "base", None) is mesh
    assert sys.getrefcount(mesh) == before + 1
    expected = np.array(v)
    del mesh
    gc.collect()
    np.testing.assert_array_equal(v, expected)  # still valid after the mesh is gone
    del v
    gc.collect()

    surface = fabrica.Surface(fabrica.read_mesh(str(liver)))
    geo = surface.geometry()
    k1 = geo["k1"]
    assert not k1.flags.owndata
    del surface, geo
    gc.collect()
    assert np.all(np.isfinite(k1))


def test_refcounts_do_not_leak(liver):
    mesh = fabrica.read_mesh(str(liver))
    cam = fabrica.Camera.view(mesh, "anterior", width=300, height=300)
    base = sys.getrefcount(mesh)
    for _ in range(20):
        _ = mesh.vertices, mesh.faces
        lines = fabrica.lines(mesh, cam)
        _ = [line.points for line in lines]
    del lines, _
    gc.collect()
    assert sys.getrefcount(mesh) == base


# --- errors ------------------------------------------------------------------

def test_errors_are_python_exceptions(tmp_path, liver):
    with pytest.raises(ValueError, match="no-such.obj"):
        fabrica.read_mesh(str(tmp_path / "no-such.obj"))
    with pytest.raises(fabrica.InputError):
        fabrica.read_mesh(str(tmp_path / "no-such.obj"))
    with pytest.raises(ValueError, match="refers to vertex"):
        fabrica.Mesh(np.zeros((3, 3)), np.array([[0, 1, 5]]))
    with pytest.raises(ValueError):
        fabrica.Mesh(np.zeros((3, 2)), np.array([[0, 1, 2]]))
    with pytest.raises(ValueError):
        fabrica.Mesh(np.array([[0, 0, np.nan], [1, 0, 0], [0, 1, 0]]), np.array([[0, 1, 2]]))
    mesh = fabrica.read_mesh(str(liver))
    cam = fabrica.Camera.view(mesh)
    with pytest.raises(ValueError, match='unknown line family "sparkles"'):
        fabrica.lines(mesh, cam, types=["contour", "sparkles"])
    with pytest.raises(ValueError, match="--ridge-threshold must be a non-negative number"):
        fabrica.lines(mesh, cam, types=["ridge"], thresholds={"ridge": -1})
    with pytest.raises(ValueError, match="--smooth must be >= 0"):
        fabrica.lines(mesh, cam, smooth=-1)
    with pytest.raises(ValueError, match="unknown view"):
        fabrica.Camera.view(mesh, "sideways")
    with pytest.raises(ValueError):
        fabrica.Camera.from_json('{"eye": [0, 0, 0], "center": [0, 0, 0]}')
    lines = fabrica.lines(mesh, cam)
    with pytest.raises(OSError, match="no-such-folder"):
        fabrica.write_svg(lines, cam, str(tmp_path / "no-such-folder" / "x.svg"))
    with pytest.raises(TypeError):
        fabrica.lines("not a mesh", cam)


# --- the CLI's outputs -------------------------------------------------------

def cli_camera(tmp_path, mesh, width=640, height=480):
    cam = fabrica.Camera.view(mesh, "anterior", width=width, height=height)
    path = tmp_path / "cam.json"
    cam.write(str(path))
    return fabrica.Camera.read(str(path)), path  # exactly what the CLI reads


def test_lines_equal_cli_json(tmp_path, liver, fabrica_cli):
    mesh = fabrica.read_mesh(str(liver))
    cam, cam_path = cli_camera(tmp_path, mesh)
    types = ["contour", "suggestive", "apparent", "ridge", "valley"]
    fabrica_cli("lines", liver, "--camera", cam_path, "--types", ",".join(types), "-q",
                "-o", tmp_path / "x.json")
    cli = json.loads((tmp_path / "x.json").read_text())
    lines = fabrica.lines(mesh, cam, types=types)
    assert len(lines) == len(cli["polylines"]) > 0
    assert lines.feature_size == cli["feature_size"]
    assert lines.segments == cli["segments"]
    for line, ref in zip(lines, cli["polylines"]):
        assert line.family == ref["family"]
        assert line.closed == ref["closed"]
        pos = np.array([v["position"] for v in ref["vertices"]])
        np.testing.assert_array_equal(line.positions, pos)
        np.testing.assert_array_equal(line.strength, np.array([v["strength"] for v in ref["vertices"]], dtype=np.float32))
        np.testing.assert_array_equal(line.visible, [v["visible"] for v in ref["vertices"]])
        np.testing.assert_array_equal(line.faces, [v["face"] for v in ref["vertices"]])
        pixels, _ = cam.project(pos)
        np.testing.assert_array_equal(line.points, pixels)
        assert line.points.shape == (len(line), 2)
    # The library's JSON is the file's, but for the two keys the CLI adds.
    mine = json.loads(lines.to_json())
    del cli["mesh"], cli["source"]
    assert mine == cli


def test_svg_and_pdf_equal_cli(tmp_path, liver, fabrica_cli):
    mesh = fabrica.read_mesh(str(liver))
    cam, cam_path = cli_camera(tmp_path, mesh)
    fabrica_cli("lines", liver, "--camera", cam_path, "--types", "contour,apparent", "--width", "2",
                "--hidden", "dashed", "-q", "-o", tmp_path / "cli.svg")
    lines = fabrica.lines(mesh, cam, types="contour,apparent")
    fabrica.write_svg(lines, cam, str(tmp_path / "py.svg"), width=2, hidden="dashed")
    assert (tmp_path / "py.svg").read_bytes() == (tmp_path / "cli.svg").read_bytes()
    assert fabrica.svg_string(lines, width=2, hidden="dashed") == (tmp_path / "cli.svg").read_text()
    if fabrica.pdf_available():
        fabrica.write_pdf(lines, cam, str(tmp_path / "py.pdf"))
        assert (tmp_path / "py.pdf").read_bytes().startswith(b"%PDF")


def test_every_family(liver):
    surface = fabrica.Surface(fabrica.read_mesh(str(liver)))
    cam = fabrica.Camera.view(surface, "left", width=512, height=512)
    lines = fabrica.lines(surface, cam, types="all", visibility=False, min_length=0)
    assert set(lines.segments) == set(fabrica.families())
    assert {line.family for line in lines} <= set(fabrica.families())
    assert sum(lines.segments.values()) > 0


def test_line_drawer_many_cameras(liver):
    surface = fabrica.Surface(fabrica.read_mesh(str(liver)))
    drawer = fabrica.LineDrawer(surface, types=["contour", "apparent"])
    for view in fabrica.VIEWS:
        cam = fabrica.Camera.view(surface, view, width=400, height=400)
        a = drawer.draw(cam)
        b = fabrica.lines(surface, cam, types=["contour", "apparent"])
        assert a.to_json() == b.to_json()


def test_geometry_equals_cli_csv(tmp_path, liver, fabrica_cli):
    fabrica_cli("geometry", liver, "-o", tmp_path / "g.csv")
    csv = np.genfromtxt(tmp_path / "g.csv", delimiter=",", names=True)
    # `fabrica geometry` reports the file as stored: orient=False.
    geo = fabrica.Surface(fabrica.read_mesh(str(liver)), orient=False).geometry()
    for key, cols in {"position": ("x", "y", "z"), "normal": ("nx", "ny", "nz"),
                      "e1": ("e1x", "e1y", "e1z"), "e2": ("e2x", "e2y", "e2z")}.items():
        np.testing.assert_array_equal(geo[key], np.column_stack([csv[c] for c in cols]))
    for key, col in {"area": "area", "k1": "k1", "k2": "k2", "H": "mean", "K": "gaussian"}.items():
        np.testing.assert_array_equal(geo[key], csv[col])
    np.testing.assert_array_equal(geo["derivatives"], np.column_stack([csv[c] for c in "abcd"]))
    np.testing.assert_array_equal(geo["valid"], csv["valid"] == 1)


@pytest.mark.skipif(not fabrica.has_hatching, reason="built without hatching")
def test_hatch_equals_cli_svg(tmp_path, liver, fabrica_cli):
    mesh = fabrica.read_mesh(str(liver))
    cam, cam_path = cli_camera(tmp_path, mesh, 400, 400)
    fabrica_cli("hatch", liver, "--camera", cam_path, "--light", "view:1,1,1", "-q",
                "-o", tmp_path / "cli.svg")
    strokes = fabrica.hatch(mesh, cam, light="view:1,1,1")
    assert len(strokes) > 10
    np.testing.assert_array_equal(strokes.points(0), strokes[0])
    assert strokes[0].shape[1] == 2 and strokes.positions(0).shape == (len(strokes[0]), 3)
    fabrica.write_hatching_svg(strokes, str(tmp_path / "py.svg"))
    assert (tmp_path / "py.svg").read_bytes() == (tmp_path / "cli.svg").read_bytes()
    with pytest.raises(ValueError, match="--light"):
        fabrica.hatch(mesh, cam, light="sideways")


@pytest.mark.skipif(not fabrica.has_hatching, reason="built without hatching")
def test_hatch_confis_equals_cli_svg(tmp_path, liver, fabrica_cli):
    mesh = fabrica.read_mesh(str(liver))
    cam, cam_path = cli_camera(tmp_path, mesh, 400, 400)
    fabrica_cli("hatch", liver, "--camera", cam_path, "--method", "confis", "--spacing", "5",
                "--contour-margin", "0.4", "-q", "-o", tmp_path / "cli.svg")
    strokes = fabrica.hatch(mesh, cam, method="confis", spacing=5, contour_margin=0.4)
    assert len(strokes) > 5
    weights = strokes.weights(0)
    assert weights.shape == (len(strokes[0]),)
    assert np.all((weights >= 0.15 - 1e-12) & (weights <= 1.0))
    fabrica.write_hatching_svg(strokes, str(tmp_path / "py.svg"))
    assert (tmp_path / "py.svg").read_bytes() == (tmp_path / "cli.svg").read_bytes()
    # Shading strokes are all weight 1.
    assert np.all(fabrica.hatch(mesh, cam).weights(0) == 1.0)
    with pytest.raises(ValueError, match="did you mean 'confis'"):
        fabrica.hatch(mesh, cam, method="confsi")
    with pytest.raises(ValueError, match="--spacing"):
        fabrica.hatch(mesh, cam, method="confis", spacing=0)


@pytest.mark.skipif(not fabrica.has_render, reason="built without the renderer")
def test_render_equals_cli_png(tmp_path, liver, fabrica_cli):
    mesh = fabrica.read_mesh(str(liver))
    cam, cam_path = cli_camera(tmp_path, mesh, 320, 240)
    result = fabrica_cli("render", liver, "--camera", cam_path, "-q", "-o", tmp_path / "cli.png",
                         check=False)
    if result.returncode == 4:
        pytest.skip("no headless OpenGL here: " + result.stderr.strip())
    assert result.returncode == 0, result.stderr
    image = fabrica.render(mesh, cam)
    assert image.shape == (240, 320, 4) and image.dtype == np.uint8
    assert image.flags.c_contiguous
    fabrica.write_png(image, str(tmp_path / "py.png"))
    import matplotlib.image as mpimg

    cli = (mpimg.imread(str(tmp_path / "cli.png")) * 255).round().astype(np.uint8)
    np.testing.assert_array_equal(image, cli)
    assert (image[..., 3] > 0).any() and (image[..., :3] < 128).any()  # lines drawn


@pytest.mark.skipif(not fabrica.has_render, reason="built without the renderer")
def test_render_lic_equals_cli_png(tmp_path, liver, fabrica_cli):
    mesh = fabrica.read_mesh(str(liver))
    cam, cam_path = cli_camera(tmp_path, mesh, 320, 240)
    result = fabrica_cli("render", liver, "--camera", cam_path, "--lic", "--lic-length", "6",
                         "--lic-strength", "0.9", "-q", "-o", tmp_path / "cli.png", check=False)
    if result.returncode == 4:
        pytest.skip("no headless OpenGL here: " + result.stderr.strip())
    assert result.returncode == 0, result.stderr
    image = fabrica.render(mesh, cam, lic=True, lic_length=6.0, lic_strength=0.9)
    import matplotlib.image as mpimg

    cli = (mpimg.imread(str(tmp_path / "cli.png")) * 255).round().astype(np.uint8)
    np.testing.assert_array_equal(image, cli)
    assert (image != fabrica.render(mesh, cam)).any()  # the texture is there
    with pytest.raises(fabrica.InputError, match="strength"):
        fabrica.render(mesh, cam, lic=True, lic_strength=2.0)


@pytest.mark.skipif(not fabrica.has_render, reason="built without the renderer")
def test_render_scene_equals_cli_png(tmp_path, fabrica_cli):
    import os
    from pathlib import Path

    import matplotlib.image as mpimg

    scene = Path(os.environ.get("FABRICA_SOURCE_DIR", Path(__file__).parents[2])) / "data" / "aneurysm-scene.json"
    result = fabrica_cli("render", scene, "--view", "left", "--size", "300x200", "-q",
                         "-o", tmp_path / "cli.png", check=False)
    if result.returncode == 4:
        pytest.skip("no headless OpenGL here: " + result.stderr.strip())
    assert result.returncode == 0, result.stderr
    image = fabrica.render_scene(str(scene), view="left", width=300, height=200)
    cli = (mpimg.imread(str(tmp_path / "cli.png")) * 255).round().astype(np.uint8)
    np.testing.assert_array_equal(image, cli)


def test_camera_json_round_trip(tmp_path, liver):
    mesh = fabrica.read_mesh(str(liver))
    cam = fabrica.Camera.view(mesh, "superior", width=200, height=100)
    back = fabrica.Camera.from_json(cam.to_json())
    assert back.to_json() == cam.to_json()
    cam.write(str(tmp_path / "c.json"))
    assert fabrica.Camera.read(str(tmp_path / "c.json")).to_json() == cam.to_json()
    assert (cam.width, cam.height) == (200, 100)


def test_vtk_round_trip(liver):
    pytest.importorskip("vtk")
    mesh = fabrica.read_mesh(str(liver))
    poly = fabrica.to_vtk(mesh)
    assert poly.GetNumberOfPoints() == mesh.vertex_count
    assert poly.GetNumberOfPolys() == mesh.face_count
    back = fabrica.from_vtk(poly)
    np.testing.assert_array_equal(back.vertices, mesh.vertices)
    np.testing.assert_array_equal(back.faces, mesh.faces)


def test_threads_draw_the_same_lines(liver):
    # The long calls release the GIL; drawing from threads (one shared
    # LineDrawer and free calls) gives the serial results.
    from concurrent.futures import ThreadPoolExecutor

    surface = fabrica.Surface(fabrica.read_mesh(str(liver)))
    cams = [fabrica.Camera.view(surface, v, width=300, height=300) for v in fabrica.VIEWS]
    serial = [fabrica.lines(surface, c, types="contour,apparent").to_json() for c in cams]
    drawer = fabrica.LineDrawer(surface, types="contour,apparent")
    with ThreadPoolExecutor(4) as pool:
        shared = list(pool.map(lambda c: drawer.draw(c).to_json(), cams))
        free = list(pool.map(lambda c: fabrica.lines(surface, c, types="contour,apparent").to_json(), cams))
    assert shared == serial and free == serial


def test_stubs_and_docstrings_cover_the_module():
    # The type stubs name exactly what the module has, class by class, and
    # every public function and class has a docstring.
    import ast
    from pathlib import Path

    stub = Path(fabrica.__file__).with_name("__init__.pyi")
    tree = ast.parse(stub.read_text())
    top = {n.name for n in tree.body if isinstance(n, (ast.FunctionDef, ast.ClassDef))}
    top |= {n.target.id for n in tree.body if isinstance(n, ast.AnnAssign)}
    public = {n for n in dir(fabrica) if not n.startswith("_")}
    assert public - {"VIEWS"} <= top | {"annotations"}
    assert top - {"Family", "Types", "MeshLike"} <= public
    for cls in (n for n in tree.body if isinstance(n, ast.ClassDef)):
        if cls.name.endswith("Error"):
            continue
        members = {f.name for f in cls.body if isinstance(f, ast.FunctionDef)}
        members |= {f.target.id for f in cls.body if isinstance(f, ast.AnnAssign)}
        real = {n for n in dir(getattr(fabrica, cls.name)) if not n.startswith("_")}
        assert real == members - {"__init__", "__len__", "__getitem__", "__iter__"}, cls.name
    for name in public:
        obj = getattr(fabrica, name)
        if callable(obj) and not name.endswith("Error") and name not in ("Line", "Lines"):
            assert obj.__doc__, name
