"""``cdbrdf curvature IN -o OUT.ply``: repair a mesh and write its curvatures for rendering.

Reads any mesh cdbrdf reads (PLY, OBJ, glTF/GLB, STL, OFF), repairs it (weld,
duplicate and degenerate faces, orientation, double-sided panels; each repair
is reported), fits the curvature over a neighbourhood given in mm and writes
the mesh as binary PLY with the signed principal curvature of larger
magnitude (``curvature_x``, Mitsuba attribute ``vertex_curvature``) and the
directional curvature along the material's x axis (``curvature_dir_x``,
``vertex_curvature_dir``), both in mm^-1, with the unit, neighbourhood and
frame recorded in the header (``cdbrdf render`` reuses them); ``--up y|z``
records the up axis there too.
"""

from __future__ import annotations

import argparse
from typing import Any

import numpy as np

from ._text import say

__all__ = ["register", "run", "LARGE_MESH_FACES", "MESH_OPTIONS", "mesh_options", "print_mesh_report"]

#: Meshes from this many faces get a progress bar while the curvature is fitted.
LARGE_MESH_FACES = 100_000


#: The options :func:`mesh_options` can add (the fields of :class:`cdbrdf.mesh.MeshSurface`).
MESH_OPTIONS: tuple[str, ...] = ("units", "neighbourhood", "frame", "up")


def mesh_options(p: Any, *, only: str | tuple[str, ...] = MESH_OPTIONS, what: str | None = None,
                 up_default: str | None = None) -> None:
    """The options of a mesh shared by ``cdbrdf curvature``, ``render --mesh`` and ``view --mesh``: unit,
    neighbourhood, frame, up axis (:class:`cdbrdf.mesh.MeshSurface`'s fields, their ranges from :mod:`cdbrdf.mesh`).

    Parameters
    ----------
    p
        A parser or an argument group.
    only
        The options to add, of :data:`MESH_OPTIONS`.
    what
        ``--units``' help after "length unit" (default: the mesh's).
    up_default
        ``--up``'s default (None: not given; the library's default is ``auto``).
    """
    from ..mesh import FRAMES, NEIGHBOURHOOD_RANGE_MM, UNITS_MM, UP_AXES
    from ._args import finite_float, keyword

    only = (only,) if isinstance(only, str) else only
    lo, hi = NEIGHBOURHOOD_RANGE_MM
    if "units" in only:
        p.add_argument("--units", type=keyword(tuple(UNITS_MM), finite_float(1e-9, 1e9, unit="mm per unit")),
                       default=None, metavar="UNIT",
                       help="length unit " + (what or "of the mesh: mm, cm, dm, m, in or a number of mm per model "
                       "unit (default: the unit the file records or states (glTF's metre, a header comment, "
                       "MakeHuman's dm), else the one a garment's or a sheet's size makes plausible, else mm)"))
    if "neighbourhood" in only:
        p.add_argument("--neighbourhood", type=finite_float(lo, hi, unit="mm"), default=None, metavar="MM",
                       help=f"diameter of the surface patch the curvature is fitted over, {lo:g} to {hi:g} mm "
                       "(default: the table's measured patch if its provenance records it, else 5)")
    if "frame" in only:
        p.add_argument("--frame", choices=FRAMES, default=None,
                       help="the material's x axis: from the UVs, a tangent attribute, or the principal "
                       "curvature directions (default auto: UVs if any, else tangents, else principal)")
    if "up" in only:
        p.add_argument("--up", choices=UP_AXES, default=up_default,
                       help="up axis of the mesh (default auto: what the file states, else from the geometry, else "
                       "the format's usual one)")


def print_mesh_report(label: str, mesh: object) -> None:
    """The repairs and notes of a prepared mesh, one line each, on standard error."""
    meta = getattr(mesh, "metadata", {})
    repairs = meta.get("repairs") or []
    if repairs:
        say(f"{label}: repaired: {', '.join(repairs)}", err=True)
    line = "; ".join(str(meta[k]) for k in ("units_note", "neighbourhood_note") if meta.get(k))
    if line:
        say(f"{label}: {line}; frame: {meta.get('frame', '?')}", err=True)
    for note in meta.get("notes") or []:
        say(f"{label}: note: {note}", err=True)


def register(sub: argparse._SubParsersAction) -> None:
    from ..mesh import MESH_FORMATS
    from ._args import existing_file, mesh_file, output_file

    p = sub.add_parser(
        "curvature",
        help="repair a mesh, compute its curvature (1/mm) and write it as a PLY for rendering",
        description="Repair a mesh (weld, duplicate and degenerate faces, orientation, double-sided "
        "panels) and fit at every vertex the signed principal curvature of larger magnitude and the "
        "normal curvature along the material's x axis (> 0 convex, in 1/mm, over a neighbourhood in "
        "mm), then write binary PLY with 'curvature_x' and 'curvature_dir_x' (Mitsuba attributes "
        "'vertex_curvature', 'vertex_curvature_dir') and the shape operator 'shape_x', 'shape_y', 'shape_z' "
        "(Mitsuba: 'vertex_shape', what a normal or height map's curvature is added to), keeping UVs and normals.",
    )
    p.add_argument("mesh", metavar="IN", type=mesh_file(),
                   help=f"input mesh ({', '.join(MESH_FORMATS)})")
    p.add_argument("-o", "--output", required=True, metavar="OUT.ply", type=output_file(".ply"),
                   help="output PLY file")
    mesh_options(p, up_default="auto")
    p.add_argument("--table", metavar="FILE", type=existing_file(".h5"), default=None,
                   help="a CDBRDF file: its measured patch sets the default neighbourhood and its kappa "
                   "range is checked (default: the paper's range)")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from ..grid import PAPER_KAPPA
    from ..mesh import prepare_mesh, read_mesh, write_ply
    from ._progress import ProgressBars

    table = None
    if args.table:
        from ..sources import open_source

        table = open_source(args.table).flat
    from ..mesh import SurfaceMaps

    mesh = read_mesh(args.mesh)
    big = mesh.faces.shape[0] >= LARGE_MESH_FACES
    with ProgressBars(quiet=args.quiet or not big, unit="vtx") as bars:
        out = prepare_mesh(mesh, units=args.units, neighbourhood_mm=args.neighbourhood, frame=args.frame,
                           maps=SurfaceMaps(from_file=False),
                           table=table, kappa_range=(float(PAPER_KAPPA.min()), float(PAPER_KAPPA.max())),
                           progress=bars.callback("curvature"))
    if args.up != "auto":  # recorded in the file, for cdbrdf render and view
        out.metadata["up"] = args.up
        out.metadata.pop("up_source", None)
    write_ply(args.output, out)
    named = mesh.metadata.get("normal_map", mesh.metadata.get("height_map"))
    if named is not None and not args.quiet:
        kind = "normal_map" if mesh.metadata.get("normal_map") is not None else "height_map"
        say(f"{args.mesh}: note: its map {getattr(named, 'name', named)} is not in the PLY: name it in the scene's "
            f"cdbrdf BSDF (<string name=\"{kind}\" .../>), which looks it up per shading point", err=True)
    if not args.quiet:
        print_mesh_report(str(args.mesh), out)
        k = out.attributes["curvature"]
        share = out.metadata.get("outside_share")
        rng = "the table's" if table is not None else "the paper's"
        say(
            f"{args.output}: {out.n_vertices} vertices, {out.faces.shape[0]} faces; curvature 1/mm: "
            f"min {k.min():.4g}, median {np.median(k):.4g}, max {k.max():.4g}"
            + (f"; {share:.1%} of the surface outside {rng} kappa range" if share is not None else ""),
            err=True,
        )
    return 0
