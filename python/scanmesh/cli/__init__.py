"""The ``scanmesh`` command: reconstruct, compare, simulate, merge, info, render, view and demo.

Exit status: 0 on success, 2 for a usage error (argparse), 1 for bad input (a scanmesh
error or a file that cannot be read or written) with one line on stderr, 130 on Ctrl-C.
Every file is written atomically (a temporary file beside it, then a rename), so an error
or an interruption never leaves a partial output file, and no command writes over its input.
"""

from __future__ import annotations

import argparse
import os
import sys
import warnings
from collections.abc import Callable, Sequence

from scanmesh import __version__
from scanmesh.cli._args import (
    _add_method_flags,
    _add_read_flags,
    _axis,
    _color_flags,
    _count,
    _holdout_fraction,
    _max_edge,
    _non_negative,
    _plane,
    _positive,
    _positive_count,
    _size,
    _vector,
    add_option_flag,
    option_help,
)
from scanmesh.cli._common import (
    _Console,
    _one_line,
    _refuse_outputs_over_inputs,
    _refuse_remote_outputs,
    _speak_flags,
)
from scanmesh.cli._parser import Parser
from scanmesh.cli.compare import HOLDOUT_FRACTION, cmd_compare
from scanmesh.cli.demo import DEMO_MESH, DEMO_PREVIEW, DEMO_TAC, cmd_demo
from scanmesh.cli.info import cmd_info
from scanmesh.cli.merge import cmd_merge
from scanmesh.cli.reconstruct import cmd_reconstruct
from scanmesh.cli.render import cmd_render
from scanmesh.cli.simulate import cmd_simulate
from scanmesh.cli.view import cmd_view
from scanmesh.errors import ScanmeshError
from scanmesh.fusion.grid import OPTIONS as MERGE_OPTIONS
from scanmesh.methods import COMPARED, DEFAULT_METHOD, METHODS
from scanmesh.scan.steep import STEEP_ANGLE_DEG


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of the ``scanmesh`` command."""
    common = argparse.ArgumentParser(add_help=False)
    common.add_argument(
        "-q",
        "--quiet",
        action="store_true",
        default=argparse.SUPPRESS,
        help="no progress bars, remarks or warnings (a --report still lists the warnings;"
        " errors are always said)",
    )
    with_json = argparse.ArgumentParser(add_help=False)
    with_json.add_argument(
        "--json", action="store_true", help="print the results as JSON and nothing else"
    )
    shape_flags = argparse.ArgumentParser(add_help=False)
    shape = shape_flags.add_argument_group("triangulation (every method)")
    shape.add_argument(
        "--plane",
        type=_plane,
        default=None,
        metavar="P",
        help="projection plane: best-fit, x, y, z or a normal vector nx,ny,nz (default:"
        " chosen by the data, fewest steep triangles among the file's up, best-fit, the"
        " axes and the principal axes)",
    )
    shape.add_argument(
        "--max-edge",
        type=_max_edge,
        default=None,
        metavar="L",
        help="drop Delaunay triangles with a longer planar edge (default 5 x median spacing;"
        " inf keeps the convex hull)",
    )
    shape.add_argument(
        "--seed", type=_count, default=None, metavar="S", help="random seed (anneal, auto; 0)"
    )

    parser = Parser(
        prog="scanmesh",
        parents=[common],
        description="Smooth, honest triangle meshes from digitized scan-line points.",
        epilog="Exit status: 0 done, 1 bad input, 2 usage error, 130 interrupted.",
    )
    parser.add_argument("--version", action="version", version=f"scanmesh {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True

    p = sub.add_parser(
        "reconstruct",
        parents=[common, with_json, shape_flags],
        help="triangulate a scan file and write the mesh",
        description="Read scan points (XYZ, CSV, PLY, NPY, VTK, DEM, LAS), triangulate them and"
        " write the mesh by its file ending (.stl, .ply, .obj, .off; .glb or .html: a view).",
    )
    p.add_argument("input", metavar="IN", help="scan file")
    _add_read_flags(p)
    p.add_argument("-o", "--output", required=True, metavar="OUT", help="mesh file to write")
    p.add_argument(
        "--method",
        choices=METHODS,
        default=None,
        help=f"method ({DEFAULT_METHOD}: the one a holdout on the scan prefers; anneal when"
        " only annealing's flags are given, or with --dask)",
    )
    p.add_argument("--report", metavar="R.json", help="also write a JSON report")
    p.add_argument("--preview", metavar="P.png", help="also write a shaded picture")
    p.add_argument(
        "--truth",
        metavar="PART",
        help="the true part (a mesh file): a .ply OUT gets each vertex's distance to it"
        " (property 'error'), the report its RMS and largest",
    )
    p.add_argument(
        "--view",
        type=_axis,
        help="--preview camera: direction from the part to the eye (default: three-quarter,"
        " from the side the surface faces)",
    )
    p.add_argument("--up", type=_axis, help="--preview camera: model direction shown upwards")
    p.add_argument(
        "--no-quality",
        dest="quality",
        action="store_false",
        help="do not measure the mesh (tac norms, smallest angle, slivers: about 4 s of CPU"
        " at 10M points); the report's quality is then null, a PLY has no tac",
    )
    dask = p.add_argument_group("on a Dask cluster")
    dask.add_argument(
        "--dask",
        metavar="ADDRESS",
        help="run on a Dask cluster: 'local' (a local cluster of processes) or a scheduler"
        " address (tcp://host:8786); IN may then be a quoted glob of files, each a run of"
        " consecutive scan lines; OUT (.stl or .ply) must be on a folder every worker sees",
    )
    dask.add_argument(
        "--workers", type=_positive_count, metavar="N", help="workers of --dask local (one a core)"
    )
    dask.add_argument(
        "--partition-lines",
        type=_positive_count,
        metavar="L",
        help="with --dask: scan lines per strip partition (default: one partition per file)",
    )
    _add_method_flags(p)
    p.set_defaults(func=cmd_reconstruct, _parser=p)

    p = sub.add_parser(
        "compare",
        parents=[common, with_json, shape_flags],
        help="run several methods on one scan; print one table",
        description="Run each method on the same points and print time and quality side by"
        " side; with --truth also the distance of each mesh to the true surface (closest-point"
        " distance at 100,000 random points on the mesh's area).",
    )
    p.add_argument("input", metavar="IN", help="scan file")
    _add_read_flags(p)
    p.add_argument("--truth", metavar="MESH", help="the true surface (a CAD mesh file)")
    p.add_argument(
        "--methods",
        nargs="+",
        choices=METHODS,
        metavar="M",
        help=f"methods to run (default: {' '.join(COMPARED)}, grid on gridded scans"
        " only; choices:"
        f" {', '.join(METHODS)})",
    )
    p.add_argument("--picture", metavar="P.png", help="write the meshes side by side")
    p.add_argument(
        "--holdout",
        type=_holdout_fraction,
        default=HOLDOUT_FRACTION,
        metavar="F",
        help="without --truth: withhold this share of the points, rebuild each method from"
        f" the rest and measure the withheld points' height error ({HOLDOUT_FRACTION:g};"
        " 0: off)",
    )
    _add_method_flags(p)
    p.set_defaults(func=cmd_compare, _parser=p)

    p = sub.add_parser(
        "simulate",
        parents=[common, with_json],
        help="scan a mesh with a virtual line digitizer",
        description="Cast parallel lines of rays onto a mesh (first hits, like a line"
        " digitizer) and write the points as XYZ text with the scan line as 4th column.",
    )
    p.add_argument("mesh", metavar="MESH", help="the part (STL, PLY, OBJ, OFF, ...)")
    p.add_argument("-o", "--output", required=True, metavar="SCAN.xyz", help="points to write")
    p.add_argument("--up", type=_axis, default="z", help="direction the digitizer looks from (z)")
    p.add_argument("--along", type=_axis, default="x", help="direction lines run (x)")
    group = p.add_mutually_exclusive_group()
    group.add_argument("--spacing", type=_positive, metavar="S", help="step along a line")
    group.add_argument(
        "--n-points", type=_count, metavar="N", help="pick the spacing for about N points"
    )
    p.add_argument("--line-spacing", type=_positive, metavar="L", help="distance between lines")
    p.add_argument(
        "--noise",
        type=_non_negative,
        default=0.0,
        metavar="SIGMA",
        help="Gaussian noise along the rays (model units, 0)",
    )
    p.add_argument("--table", action="store_true", help="rays that miss hit the table")
    p.add_argument("--seed", type=_count, default=0, metavar="S", help="noise seed (0)")
    p.set_defaults(func=cmd_simulate, _parser=p)

    p = sub.add_parser(
        "merge",
        parents=[common, with_json],
        help="one closed mesh from aligned range scans taken from several sides",
        description="Fuse range scans of one part, each in its scanner's coordinates (the"
        " scanner towards +z) with its pose, into one closed mesh: signed distances along"
        " each scan's rays averaged in a voxel grid, the space the rays crossed carved"
        " out. Every face is labelled measured, inferred (closed by carving) or filled"
        " (no evidence); a .ply output stores the label as a face property.",
    )
    p.add_argument(
        "inputs",
        nargs="+",
        metavar="IN",
        help="a Stanford .conf file (its scans and poses), or scan files with --poses",
    )
    p.add_argument("-o", "--output", required=True, metavar="MESH", help="mesh to write")
    p.add_argument(
        "--poses",
        metavar="POSES.json",
        help="scanner-to-world 4x4 matrices: a list, one per scan, or {file name: matrix}"
        " (default: the identity, or the direction a simulated scan records)",
    )
    p.add_argument(
        "--toward", type=_axis, default="z", help="where the scanner sits in a scan's own axes (z)"
    )
    merge_flags = p.add_argument_group("options of the fusion")
    for option in MERGE_OPTIONS:
        add_option_flag(merge_flags, option, option_help(option))
    p.add_argument(
        "--forward-rotation",
        action="store_true",
        help="read a .conf file's quaternions as world = R(q) p + t (default: R(q)^T p + t,"
        " which aligns the Stanford scans)",
    )
    p.set_defaults(func=cmd_merge, _parser=p)

    p = sub.add_parser(
        "info",
        parents=[common, with_json],
        help="describe a scan file, or judge a mesh file",
        description="A scan: points, scan lines, extent, median spacing, noise and the share"
        f" of steep Delaunay triangles (normal more than {STEEP_ANGLE_DEG:g} deg from the"
        " projection normal). A mesh (.stl, .obj, .off, .glb, or a .ply with faces): tac"
        " norms, smallest angle and sliver share, as every method is judged.",
    )
    p.add_argument("input", metavar="IN", help="scan or mesh file")
    _add_read_flags(p)
    p.add_argument(
        "--plane",
        type=_plane,
        default=None,
        metavar="P",
        help="projection plane (best-fit, x, y, z or nx,ny,nz; default: chosen by the data)",
    )
    p.set_defaults(func=cmd_info, _parser=p)

    p = sub.add_parser(
        "render",
        parents=[common],
        help="flat-shaded PNG picture of a mesh",
        description="Draw a mesh flat-shaded (each facet visible), seen from the side it faces.",
    )
    p.add_argument("mesh", metavar="MESH", help="mesh file")
    p.add_argument("-o", "--output", required=True, metavar="PNG", help="picture to write")
    p.add_argument("--view", type=_axis, help="direction from the part to the eye")
    p.add_argument("--up", type=_axis, help="model direction shown upwards")
    p.add_argument("--size", type=_size, default=(800, 600), metavar="WxH", help="(800x600)")
    p.add_argument(
        "--wire",
        action="store_true",
        help="draw the triangle edges (too small to tell apart: the middle of the mesh, zoomed)",
    )
    _color_flags(p)
    p.add_argument(
        "--no-bar",
        dest="bar",
        action="store_false",
        help="with --color: the picture alone (--size exactly), no title and colour bar",
    )
    p.set_defaults(func=cmd_render, _parser=p)

    p = sub.add_parser(
        "view",
        parents=[common],
        help="3-D view of a mesh in the web browser (an offline HTML page)",
        description="Write a self-contained HTML page that shows a mesh in 3-D (drag to"
        " turn, wheel to zoom; no network needed) and open it in the web browser.",
    )
    p.add_argument("mesh", metavar="MESH", help="mesh file")
    p.add_argument(
        "-o",
        "--output",
        metavar="FILE",
        help="page to write (.html), or a .glb file for other viewers (default: a new"
        " temporary folder)",
    )
    p.add_argument("--view", type=_axis, help="first view: direction from the part to the eye")
    p.add_argument("--up", type=_axis, help="model direction shown upwards")
    p.add_argument("--no-open", action="store_true", help="write the page, do not open it")
    _color_flags(p)
    p.set_defaults(func=cmd_view, _parser=p)

    p = sub.add_parser(
        "demo",
        parents=[common, with_json],
        help="scan a creased CAD part with noise and show what annealing gains",
        description="Scan the embedded fandisk (a CAD part with creases) turned so that its"
        " creases cross the scan lines, with noise; reconstruct it by Delaunay and by"
        f" annealing (seed 0); write {DEMO_MESH} (annealed), {DEMO_PREVIEW} (both,"
        f" shaded) and {DEMO_TAC} (both, coloured by tac on one scale) into the current"
        " folder or -o DIR, and print both meshes' quality and height error against the"
        " part.",
    )
    p.add_argument(
        "-o",
        "--output-dir",
        default=".",
        metavar="DIR",
        help="folder for the files, made if missing (default: the current folder)",
    )
    p.set_defaults(func=cmd_demo, _parser=p)
    return parser


#: Flags whose value may start with a minus sign (a vector like -1,-1,1).
VECTOR_FLAGS = ("--plane", "--up", "--along", "--view", "--toward")


def _join_vectors(argv: Sequence[str]) -> list[str]:
    """``--view -1,-1,1`` as ``--view=-1,-1,1``: argparse takes a value starting with '-'
    for a flag unless it looks like one negative number."""
    out: list[str] = []
    items = list(argv)
    k = 0
    while k < len(items):
        item = items[k]
        nxt = items[k + 1] if k + 1 < len(items) else None
        if item in VECTOR_FLAGS and nxt is not None and nxt.startswith("-") and _vector(nxt):
            out.append(f"{item}={nxt}")
            k += 2
            continue
        out.append(item)
        k += 1
    return out


def main(argv: Sequence[str] | None = None) -> int:
    """Run the ``scanmesh`` command; return its exit status."""
    try:
        parser = build_parser()
        args = parser.parse_args(_join_vectors(sys.argv[1:] if argv is None else argv))
        con = _Console(quiet=getattr(args, "quiet", False), as_json=getattr(args, "json", False))
        run: Callable[[argparse.Namespace, _Console], int] = args.func
        _refuse_remote_outputs(args)  # every command's outputs are files
        _refuse_outputs_over_inputs(args)  # ... and none of them is an input
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("always")  # every warning reaches the report
                warnings.showwarning = con.warn
                return run(args, con)
        finally:
            con.close()
    except KeyboardInterrupt:
        print("scanmesh: interrupted", file=sys.stderr, flush=True)
        if argv is None:
            # The command's own process (not a caller's): ended now. The interpreter's
            # shutdown took 0.3-0.5 s (modules torn down) and up to 1.2 s beside an abandoned
            # native call; temporaries are already removed (writers clean up as the
            # interrupt passes).
            sys.stdout.flush()
            os._exit(130)
        return 130
    except BrokenPipeError:
        # the reader of stdout went away (``scanmesh info x --json | head``): stop quietly,
        # and keep Python from reporting the pipe again when it flushes stdout at exit
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 1
    except (ScanmeshError, FileNotFoundError, OSError) as exc:
        print(f"scanmesh: error: {_speak_flags(_one_line(exc))}", file=sys.stderr, flush=True)
        return 1
    except MemoryError as exc:  # numpy's, or Python's: the limit stops the run, not a bug
        what = _one_line(exc) or "an allocation failed"
        print(f"scanmesh: error: out of memory: {what}", file=sys.stderr, flush=True)
        return 1
