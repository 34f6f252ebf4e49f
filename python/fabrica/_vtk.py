"""Conversion between fabrica.Mesh and VTK's vtkPolyData (PyVista, 3D Slicer).

Needs the ``vtk`` Python package (Debian: python3-vtk9); imported only when
called, so fabrica works without it.
"""


def _vtk():
    try:
        import vtk  # noqa: F401
        from vtk.util import numpy_support
    except ImportError as e:  # pragma: no cover - depends on the machine
        from ._fabrica import UnavailableError

        raise UnavailableError(
            "VTK conversion needs the vtk Python package (Debian: python3-vtk9); "
            "install it or pass numpy arrays to fabrica.Mesh"
        ) from e
    return vtk, numpy_support


def to_vtk(mesh):
    """The mesh (a fabrica.Mesh or Surface) as a new vtkPolyData of triangles."""
    import numpy as np

    vtk, ns = _vtk()
    m = mesh.mesh if hasattr(mesh, "geometry") else mesh
    points = vtk.vtkPoints()
    points.SetData(ns.numpy_to_vtk(np.array(m.vertices, dtype=np.float64), deep=True))
    faces = np.asarray(m.faces, dtype=np.int64)
    cells = vtk.vtkCellArray()
    offsets = np.arange(0, 3 * len(faces) + 1, 3, dtype=np.int64)
    cells.SetData(
        ns.numpy_to_vtkIdTypeArray(offsets, deep=True),
        ns.numpy_to_vtkIdTypeArray(faces.ravel().copy(), deep=True),
    )
    poly = vtk.vtkPolyData()
    poly.SetPoints(points)
    poly.SetPolys(cells)
    return poly


def from_vtk(polydata, space="lps"):
    """A fabrica.Mesh from a vtkPolyData (polygons fan-triangulated, strips unrolled)."""
    import numpy as np

    from ._fabrica import InputError, Mesh

    vtk, ns = _vtk()
    if polydata is None or polydata.GetNumberOfPoints() == 0:
        raise InputError("from_vtk: the vtkPolyData has no points")
    tri = vtk.vtkTriangleFilter()
    tri.SetInputData(polydata)
    tri.PassVertsOff()
    tri.PassLinesOff()
    tri.Update()
    out = tri.GetOutput()
    vertices = ns.vtk_to_numpy(polydata.GetPoints().GetData()).astype(np.float64)
    if out.GetNumberOfPolys() == 0:
        raise InputError("from_vtk: the vtkPolyData has no polygons")
    conn = ns.vtk_to_numpy(out.GetPolys().GetConnectivityArray())
    faces = conn.reshape(-1, 3)
    out_points = ns.vtk_to_numpy(out.GetPoints().GetData()).astype(np.float64)
    if out_points.shape != vertices.shape or not np.array_equal(out_points, vertices):
        vertices = out_points
    return Mesh(vertices, faces, space=space)
