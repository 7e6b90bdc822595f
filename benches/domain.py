"""How honest is each domain? Air covered and shadow missed against the CAD truth.

    python benches/domain.py                    # every part of benches/quality.py
    python benches/domain.py --parts conrod --anneal   # and annealing on each domain
    python benches/domain.py --parts conrod --figure benches/figures/domain_rod_corner.png

A planar method chooses the part of the plane its mesh covers: trimmed Delaunay keeps
triangles whose edges are at most ``k`` x the median spacing, the strips keep what lies
between consecutive scan lines. Flips never change it, so annealing inherits the domain of
its initial mesh. Per part (the scans of ``benches/quality.py``) and domain: the area covered
where the true part casts no shadow on the projection plane ("air") and the part's shadow
left uncovered ("missed"), both in % of the shadow (:func:`scanmesh.evaluate.truth.domain_error`,
4 million rays), and the interior vertices (the ones tac is summed over). With ``--anneal``,
default annealing (seed 0) from each trimmed Delaunay, scored against Delaunay on the same
domain and against the default Delaunay: tac_1, height RMS (100,000 samples) and slivers.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import numpy as np
from quality import CAD, PARTS, machine, scan

import scanmesh
from scanmesh.evaluate.truth import TrueSurface, domain_error, height_error
from scanmesh.stages.optimal_program import _interior_mask
from scanmesh.stages.options import MAX_EDGE_FACTOR

#: Trimming lengths in multiples of the median spacing (5 is the default).
FACTORS = (3.0, 4.0, 5.0, 6.0, 7.0, 8.0, math.inf)


def interior_vertices(faces: np.ndarray) -> int:
    """Used vertices that no boundary edge (an edge of one face only) touches."""
    n = int(faces.max()) + 1
    used = np.bincount(faces.ravel(), minlength=n) > 0
    return int((_interior_mask(n, faces) & used).sum())


def domains(points: np.ndarray, lines: np.ndarray, plane: str):
    """(label, trimming factor or None, Surface) of every domain compared."""
    default = scanmesh.delaunay(points, plane=plane)
    spacing = default.options["max_edge"] / MAX_EDGE_FACTOR
    for k in FACTORS:
        label = f"Delaunay, trim {k:g}x" + (" (default)" if k == MAX_EDGE_FACTOR else "")
        if k == MAX_EDGE_FACTOR:
            yield label, k, default
        else:
            yield label, k, scanmesh.delaunay(points, plane=plane, max_edge=k * spacing)
    strips = scanmesh.reconstruct(points, "shortest-path", lines=lines, plane=plane)
    yield "strips (shortest path)", None, strips


def anneal_table(part: str, rows: list[tuple]) -> None:
    """Annealing from each finitely trimmed Delaunay; ratios against Delaunay."""
    cad, _, plane = PARTS[part]
    points, _ = scan(part)
    truth = TrueSurface(CAD / cad)
    print(
        f"\n**{part}**: annealing (defaults, seed 0) from each trimmed Delaunay\n\n"
        "| trim | Delaunay tac_1 | anneal tac_1 | / same-trim Del. | / default Del. |"
        " Delaunay h_rms | anneal h_rms | / same-trim Del. | / default Del. | slivers |"
        " air | missed |"
    )
    print("|---|" + "---|" * 11)
    scored = []
    for _, k, surface, d in rows:
        if k is None or not math.isfinite(k):
            continue
        annealed = scanmesh.reconstruct(
            points, "anneal", plane=plane, max_edge=surface.options["max_edge"], seed=0
        )
        h = [height_error(s, truth, seed=0)["h_rms"] for s in (surface, annealed)]
        scored.append((k, surface.quality.tac_1, annealed.quality.tac_1, *h, annealed, d))
    base = next(r for r in scored if r[0] == MAX_EDGE_FACTOR)
    for k, del_tac, tac, del_h, h, annealed, d in scored:
        print(
            f"| {k:g}x | {del_tac:.4g} | {tac:.4g} | {tac / del_tac:.3f} | {tac / base[1]:.3f} |"
            f" {del_h:.3g} | {h:.3g} | {h / del_h:.3f} | {h / base[3]:.3f} |"
            f" {100 * annealed.quality.sliver_fraction:.2f} % | {100 * d['air_share']:.3f} % |"
            f" {100 * d['missed_share']:.2f} % |",
            flush=True,
        )


#: The rod's big-eye corner where the shaft's side meets the eye (x, z window, inches).
ROD_CORNER = ((0.70, 0.93), (0.53, 0.67))


def corner_figure(path: Path, rows: list[tuple], truth: TrueSurface, factors=(3.0, 5.0, 8.0)):
    """The rod's big-eye corner under several trimming lengths: mesh edges over the part's
    shadow, air (mesh outside the shadow) in red, missed shadow in blue (rays every 1/400
    of the window, as domain_error casts them)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.colors import ListedColormap

    from scanmesh.evaluate.digitizer import cast_grid

    (x0, x1), (z0, z1) = ROD_CORNER
    step = (x1 - x0) / 400
    shape = (int((x1 - x0) / step) + 1, int((z1 - z0) / step) + 1)

    def covered(tri: np.ndarray) -> np.ndarray:
        _, face = cast_grid(tri, np.zeros(tri.shape[:2]), (x0, z0), (step, step), shape)
        return (face >= 0).reshape(shape[1], shape[0])

    shadow = covered(truth.triangles[:, :, [0, 2]])
    chosen = [r for r in rows if r[1] in factors]
    fig, axes = plt.subplots(1, len(chosen), figsize=(5.2 * len(chosen), 3.6))
    colours = ListedColormap(["white", "#fde3b5", "#d62728", "#1f77b4"])
    for ax, (label, _, surface, d) in zip(np.atleast_1d(axes), chosen, strict=True):
        v = surface.vertices[:, [0, 2]]
        mesh = covered(v[surface.faces])
        # 0 outside both, 1 shadow and mesh, 2 air, 3 missed
        code = np.where(shadow & mesh, 1, np.where(mesh, 2, np.where(shadow, 3, 0)))
        ax.imshow(code, origin="lower", extent=(x0, x1, z0, z1), cmap=colours, vmin=0, vmax=3)
        ax.triplot(v[:, 0], v[:, 1], surface.faces, lw=0.5, color="0.3")
        ax.set_xlim(x0, x1)
        ax.set_ylim(z0, z1)
        ax.set_aspect("equal")
        ax.set_title(
            f"{label}: air {100 * d['air_share']:.3f} %, missed {100 * d['missed_share']:.2f} %"
            " (whole rod)",
            fontsize=9,
        )
        ax.set_xlabel("x (in)")
    np.atleast_1d(axes)[0].set_ylabel("z (in)")
    fig.suptitle("rod, big-eye corner: shadow (tan), air (red), missed (blue)", fontsize=10)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--parts", nargs="+", choices=list(PARTS), default=list(PARTS))
    parser.add_argument("--anneal", action="store_true", help="also anneal on each domain")
    parser.add_argument("--figure", type=Path, help="PNG of the rod's corner (with conrod)")
    args = parser.parse_args()
    print(f"machine: {machine()}\n")
    print("| part | domain | air | missed | air + missed | interior vertices | ray spacing |")
    print("|---|---|---|---|---|---|---|")
    measured = {}
    for part in args.parts:
        cad, _, plane = PARTS[part]
        points, lines = scan(part)
        truth = TrueSurface(CAD / cad)
        measured[part] = []
        for label, k, surface in domains(points, lines, plane):
            d = domain_error(surface, truth)
            measured[part].append((label, k, surface, d))
            print(
                f"| {part} | {label} | {100 * d['air_share']:.3f} % |"
                f" {100 * d['missed_share']:.2f} % |"
                f" {100 * (d['air_share'] + d['missed_share']):.2f} % |"
                f" {interior_vertices(surface.faces):,} | {d['step']:.2g} |",
                flush=True,
            )
    if args.figure is not None and "conrod" in measured:
        corner_figure(args.figure, measured["conrod"], TrueSurface(CAD / PARTS["conrod"][0]))
    if args.anneal:
        for part, rows in measured.items():
            anneal_table(part, rows)
    print(f"\nmachine after: {machine()}")


if __name__ == "__main__":
    main()
