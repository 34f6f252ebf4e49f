"""Feature lines of a mesh to SVG (docs/python.md).

    python3 lines_svg.py MESH OUT.svg [VIEW]
"""
import sys

import fabrica


def main(mesh_path, out_path, view="anterior"):
    mesh = fabrica.read_mesh(mesh_path)
    cam = fabrica.Camera.view(mesh, view, width=800, height=600)
    lines = fabrica.lines(mesh, cam, types=["contour", "apparent"])
    for family, count in lines.segments.items():
        print(f"{family}: {count} segments")
    print(f"{len(lines)} polylines, feature size {lines.feature_size:.3g} mm")
    fabrica.write_svg(lines, cam, out_path)


if __name__ == "__main__":
    main(*sys.argv[1:])
