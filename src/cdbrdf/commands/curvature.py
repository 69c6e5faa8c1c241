"""``cdbrdf curvature IN.ply|IN.obj -o OUT.ply``: per-vertex curvature for rendering.

Writes the mesh (positions, normals, UVs kept) with the signed principal
curvature of larger magnitude in mm^-1 as the PLY vertex property
``curvature_x``, which Mitsuba loads as the mesh attribute
``vertex_curvature`` read by the ``cdbrdf`` BSDF.
"""

from __future__ import annotations

import argparse
import sys

import numpy as np

__all__ = ["register", "run", "LARGE_MESH_FACES"]

#: Meshes from this many faces get a note before the (single, silent) libigl call.
LARGE_MESH_FACES = 200_000


def register(sub: argparse._SubParsersAction) -> None:
    from ..curvature import IGL_RADIUS, MAX_RADIUS
    from ..render.scenes import UNITS_MM
    from ._args import existing_file, int_range, output_file

    p = sub.add_parser(
        "curvature",
        help="compute per-vertex curvature of a mesh and write it as a PLY for rendering",
        description="Compute the signed principal curvature of larger magnitude at every vertex "
        "(> 0 convex relative to the counter-clockwise outward normal, in 1/mm) and write the "
        "mesh as binary PLY with the property 'curvature_x' (Mitsuba attribute "
        "'vertex_curvature'), keeping UVs and normals.",
    )
    p.add_argument("mesh", metavar="IN", type=existing_file(".ply", ".obj"), help="input mesh (.ply or .obj)")
    p.add_argument("-o", "--output", required=True, metavar="OUT.ply", type=output_file(),
                   help="output PLY file")
    p.add_argument("--units", choices=sorted(UNITS_MM), default="mm",
                   help="length unit of the input mesh (default: mm); the curvature is written in 1/mm")
    p.add_argument("--radius", type=int_range(IGL_RADIUS, MAX_RADIUS), default=IGL_RADIUS,
                   help=f"libigl neighbourhood radius in average edge lengths, {IGL_RADIUS} to "
                   f"{MAX_RADIUS} (default: {IGL_RADIUS}); the work grows as the radius squared")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from ..curvature import max_curvature
    from ..render.meshio import read_mesh, write_ply
    from ..render.scenes import UNITS_MM

    if not str(args.output).lower().endswith(".ply"):
        raise ValueError(f"{args.output}: the output must be a .ply file")
    mesh = read_mesh(args.mesh)
    if not args.quiet and mesh.faces.shape[0] >= LARGE_MESH_FACES:
        print(f"{args.mesh}: {mesh.faces.shape[0]:,} faces; estimating the curvature "
              f"(radius {args.radius}) can take a while", file=sys.stderr)
    k = max_curvature(mesh.vertices, mesh.faces, normals=mesh.normals, radius=args.radius)
    mesh.attributes["curvature"] = k / UNITS_MM[args.units]
    write_ply(args.output, mesh)
    if not args.quiet:
        kk = mesh.attributes["curvature"]
        print(
            f"{args.output}: {mesh.n_vertices} vertices, {mesh.faces.shape[0]} faces, "
            f"UVs {'yes' if mesh.uv is not None else 'NO (rendering needs them)'}; curvature 1/mm: "
            f"min {kk.min():.4g}, median {np.median(kk):.4g}, max {kk.max():.4g}",
            file=sys.stderr,
        )
    return 0
