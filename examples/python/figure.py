"""A matplotlib figure: the mean curvature on the mesh's vertices next to
its feature lines, from the same camera (docs/python.md).

    python3 figure.py MESH OUT.png
"""
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import fabrica  # noqa: E402


def main(mesh_path, out_path):
    surface = fabrica.Surface(fabrica.read_mesh(mesh_path))
    cam = fabrica.Camera.view(surface, "anterior", width=600, height=600)
    geo = surface.geometry()
    pixels, depth = cam.project(geo["position"])
    order = np.argsort(-depth)  # far to near, so near points are drawn last

    fig, (left, right) = plt.subplots(1, 2, figsize=(10, 5))
    h = np.clip(geo["H"], *np.percentile(geo["H"], [2, 98]))
    left.scatter(pixels[order, 0], pixels[order, 1], c=h[order], s=2, cmap="coolwarm")
    left.set_title("mean curvature H (1/mm)")
    for line in fabrica.lines(surface, cam, types=["contour", "suggestive", "ridge"]):
        visible = line.visible
        pts = np.where(visible[:, None], line.points, np.nan)  # gaps where hidden
        right.plot(pts[:, 0], pts[:, 1], lw=0.8, color="red" if line.family == "ridge" else "black")
    right.set_title("contours, suggestive contours, ridges")
    for ax in (left, right):
        ax.set_xlim(0, cam.width)
        ax.set_ylim(cam.height, 0)
        ax.set_aspect("equal")
        ax.axis("off")
    fig.savefig(out_path, dpi=100)
    print(f"wrote {out_path}")


if __name__ == "__main__":
    main(*sys.argv[1:])
