"""fabrica: feature lines, hatching and focus-and-context illustrations of meshes.

The same pipelines as the ``fabrica`` command line (docs/python.md)::

    import fabrica
    mesh = fabrica.read_mesh("veins.stl")          # mesh.vertices (n,3) float64, mesh.faces (m,3) int32
    cam = fabrica.Camera.view(mesh, "anterior", width=800, height=600)
    lines = fabrica.lines(mesh, cam, types=["contour", "apparent"])
    for line in lines:                              # .family, .points (k,2), .strength (k,)
        ...
    fabrica.write_svg(lines, cam, "out.svg")
    geo = fabrica.Surface(mesh).geometry()          # "k1", "k2", "H", "K", "normal", ...

Errors raise InputError (a ValueError) for bad input, OutputError (an
OSError) when a file cannot be written and UnavailableError (a
RuntimeError) when a facility (PDF, headless OpenGL) is missing, each with
the command line's one-line message.
"""

from ._fabrica import (  # noqa: F401
    Camera,
    Error,
    InputError,
    Line,
    LineDrawer,
    Lines,
    Mesh,
    OutputError,
    Surface,
    UnavailableError,
    families,
    has_hatching,
    has_render,
    lines,
    pdf_available,
    read_mesh,
    svg_string,
    write_lines_json,
    write_mesh,
    write_pdf,
    write_svg,
)
from ._vtk import from_vtk, to_vtk  # noqa: F401

if has_hatching:
    from ._fabrica import Strokes, hatch, write_hatching_svg  # noqa: F401
if has_render:
    from ._fabrica import render, render_scene, write_png  # noqa: F401

VIEWS = ("anterior", "posterior", "left", "right", "superior", "inferior")

__all__ = [name for name in dir() if not name.startswith("_")]
