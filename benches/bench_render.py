"""Time flat-shaded rendering of a 1M-triangle mesh: numpy z-buffer versus matplotlib.

    python benches/bench_render.py                 # all three, 1,000,000 triangles
    python benches/bench_render.py --triangles 100000 --only trisurf

Renderers, each writing an 800 x 600 PNG of the same mesh seen from the same direction:

- zbuffer: scanmesh.present.render.render_mesh (orthographic z-buffer in numpy),
  supersample 1 and 2;
- polycollection: matplotlib PolyCollection, faces sorted far to near (painter's algorithm),
  colours from the same Lambert shading, no edges, no anti-aliasing;
- trisurf: mpl_toolkits.mplot3d plot_trisurf with its own shading.

The mesh is a wavy height field (a grid of 2 triangles per cell). Prints a Markdown table.
"""

from __future__ import annotations

import argparse
import math
import tempfile
import time
from pathlib import Path

import numpy as np

from scanmesh.present.render import COLOR, LIGHT, camera, render_mesh

VIEW = (-0.55, -1.0, 0.9)
SIZE = (800, 600)


def height_field(n_triangles: int) -> tuple[np.ndarray, np.ndarray]:
    """A 2:1 grid of about n_triangles triangles over z = wavy(x, y)."""
    rows = max(1, round(math.sqrt(n_triangles / 4)))
    cols = max(1, round(n_triangles / (2 * rows)))
    x, y = np.meshgrid(np.linspace(0, 2, cols + 1), np.linspace(0, 1, rows + 1))
    z = 0.08 * np.sin(7 * x) * np.cos(9 * y) + 0.05 * np.exp(-20 * ((x - 1) ** 2 + (y - 0.5) ** 2))
    vertices = np.column_stack((x.ravel(), y.ravel(), z.ravel()))
    idx = np.arange((rows + 1) * (cols + 1)).reshape(rows + 1, cols + 1)
    a, b = idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel()
    c, d = idx[1:, :-1].ravel(), idx[1:, 1:].ravel()
    faces = np.concatenate([np.column_stack((a, b, d)), np.column_stack((a, d, c))])
    return vertices, faces


def polycollection(vertices: np.ndarray, faces: np.ndarray, path: Path) -> None:
    from matplotlib.collections import PolyCollection
    from matplotlib.figure import Figure

    frame = camera(VIEW, "z")
    local = vertices @ frame.T
    tri = local[faces]
    normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    normal /= np.linalg.norm(normal, axis=1)[:, None]
    light = np.asarray(LIGHT) / np.linalg.norm(LIGHT)
    rgb = (0.25 + 0.75 * np.abs(normal @ light))[:, None] * np.asarray(COLOR)
    order = np.argsort(tri[:, :, 2].mean(axis=1))  # far first
    fig = Figure(figsize=(SIZE[0] / 100, SIZE[1] / 100), dpi=100)
    ax = fig.add_axes((0, 0, 1, 1))
    ax.add_collection(
        PolyCollection(
            tri[order, :, :2], facecolors=rgb[order], edgecolors="none", antialiased=False
        )
    )
    ax.set_xlim(local[:, 0].min(), local[:, 0].max())
    ax.set_ylim(local[:, 1].min(), local[:, 1].max())
    ax.set_aspect("equal")
    ax.set_axis_off()
    fig.savefig(path, dpi=100)


def trisurf(vertices: np.ndarray, faces: np.ndarray, path: Path) -> None:
    from matplotlib.figure import Figure

    fig = Figure(figsize=(SIZE[0] / 100, SIZE[1] / 100), dpi=100)
    ax = fig.add_subplot(projection="3d")
    ax.plot_trisurf(
        vertices[:, 0],
        vertices[:, 1],
        vertices[:, 2],
        triangles=faces,
        color=COLOR,
        shade=True,
        linewidth=0,
        antialiased=False,
    )
    ax.view_init(elev=35, azim=-120)
    ax.set_axis_off()
    fig.savefig(path, dpi=100)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--triangles", type=int, default=1_000_000)
    parser.add_argument("--only", choices=["zbuffer", "polycollection", "trisurf"])
    parser.add_argument("--repeat", type=int, default=3, help="z-buffer runs (best is kept)")
    args = parser.parse_args()
    vertices, faces = height_field(args.triangles)
    print(f"mesh: {len(vertices):,} vertices, {len(faces):,} triangles; picture {SIZE}\n")
    print("| renderer | first run (s) | best of runs (s) |")
    print("|---|---|---|")
    out = Path(tempfile.mkdtemp(prefix="bench_render_"))
    jobs = {
        "zbuffer": [
            (f"scanmesh z-buffer (numpy), supersample {ss}", ss, args.repeat) for ss in (1, 2)
        ],
        "polycollection": [("matplotlib PolyCollection, painter's sort", None, 1)],
        "trisurf": [("matplotlib mplot3d plot_trisurf", None, 1)],
    }
    for name, runs in jobs.items():
        if args.only and name != args.only:
            continue
        for label, ss, repeat in runs:
            times = []
            for _ in range(repeat):
                path = out / f"{name}_{ss}.png"
                start = time.perf_counter()
                if name == "zbuffer":
                    render_mesh((vertices, faces), path, size=SIZE, view=VIEW, supersample=ss)
                elif name == "polycollection":
                    polycollection(vertices, faces, path)
                else:
                    trisurf(vertices, faces, path)
                times.append(time.perf_counter() - start)
            best = f"{min(times):.2f} ({repeat})" if repeat > 1 else "-"
            print(f"| {label} | {times[0]:.2f} | {best} |", flush=True)
    print(f"\npictures in {out}")


if __name__ == "__main__":
    main()
