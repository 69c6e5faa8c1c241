"""``cdbrdf export TABLE (--scene sine|swatch | --mesh MESH) -o OUT.glb|.gltf``: a glTF 2.0 asset.

The mesh as the renderer prepares it (repaired, welded, its curvature in
1/mm, turned upright, in metres), the table in the
``CDBRDF_materials_curvature_brdf`` extension and the standard material
fitted to the flat BRDF (:func:`cdbrdf.export.gltf.export_gltf`);
``--materialx OUT.mtlx`` also writes that material as a MaterialX document
(:mod:`cdbrdf.export.materialx`). ``docs/export.md`` describes the asset.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from ..errors import OptionError
from ._text import say

__all__ = ["register", "run"]


def register(sub: argparse._SubParsersAction) -> None:
    from ..mesh import CURVATURE_MODES, MESH_FORMATS
    from ..render.spec import SCENES
    from ._args import existing_file, mesh_file, output_file
    from ._maps import add_map_options
    from .curvature import mesh_options

    p = sub.add_parser(
        "export",
        help="write a table on a surface as a glTF 2.0 asset (the CDBRDF in a vendor extension, a standard "
        "fallback material) and optionally the fallback as MaterialX",
        description="Write a CDBRDF on the sine sheet, the swatch or a mesh as one glTF 2.0 asset (.glb, or a "
        "self-contained .gltf): the mesh as the renderer prepares it (repaired, welded, upright, in metres; "
        "normals, MikkTSpace tangents, UVs, the signed curvature in 1/mm per vertex as _CURVATURE), the table "
        "(and a normal or height map's curvature map) as 16-bit textures under the "
        "CDBRDF_materials_curvature_brdf extension, and the standard "
        "material (base colour, roughness, sheen, anisotropy) fitted to the flat BRDF, which every glTF viewer "
        "shows. cdbrdf view OUT.glb renders it in the browser; cdbrdf.load(OUT.glb) reads the table back.",
        epilog="example: cdbrdf export denim.h5 --mesh shirt.obj --units mm -o shirt.glb --materialx denim.mtlx",
    )
    p.add_argument("file", metavar="TABLE", type=existing_file(), help="a CDBRDF file (.h5), RGB or grey")
    p.add_argument("-o", "--output", required=True, metavar="OUT", type=output_file(".glb", ".gltf"),
                   help="the asset: .glb (binary) or .gltf (one JSON file, its data embedded)")
    what = p.add_mutually_exclusive_group()
    what.add_argument("--scene", choices=tuple(SCENES), default=None,
                      help="a built-in surface: " + "; ".join(f"{k}: {v}" for k, v in SCENES.items()))
    what.add_argument("--mesh", metavar="MESH", type=mesh_file(),
                      help=f"a mesh ({', '.join(MESH_FORMATS)}), lengths in --units")
    mesh_options(p)  # --units, --neighbourhood, --frame, --up (default None: not given)
    add_map_options(p.add_argument_group("maps laid on --mesh by its UVs (docs/rendering.md, \"Maps\"): baked per "
                                         "texel into the asset's curvature map, or with --bake vertex into "
                                         "_CURVATURE"))
    p.add_argument("--curvature", choices=CURVATURE_MODES, default="max",
                   help="the curvature in _CURVATURE: max (the paper's: principal curvature of larger magnitude) "
                   "or directional (normal curvature along the material's x axis; its direction as "
                   "_CURVATURE_DIRECTION) (default: max)")
    p.add_argument("--materialx", metavar="OUT.mtlx", type=output_file(".mtlx"), default=None,
                   help="also write the fallback material as a MaterialX document (standard_surface with sheen)")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from ..export.gltf import build_gltf, export_mesh, write_gltf
    from ..mesh import MeshSurface
    from ..sources import open_source
    from ._maps import MAP_OPTIONS, surface_maps
    from .curvature import print_mesh_report

    if args.scene is None and args.mesh is None:
        raise OptionError("give --scene sine, --scene swatch or --mesh MESH: the surface the table is put on")
    if args.scene is not None:
        given = [o for o in ("units", "neighbourhood", "frame", "up", *MAP_OPTIONS) if getattr(args, o) is not None]
        if given:
            raise OptionError(f"--{given[0].replace('_', '-')}: only with --mesh (the {args.scene} scene is in mm, "
                              "z up, with its analytic curvature)")
    if args.materialx is not None and Path(args.materialx).resolve() == Path(args.output).resolve():
        raise OptionError("--materialx: must differ from -o")
    table = open_source(args.file).flat
    surface = args.scene or MeshSurface(args.mesh, units=args.units, neighbourhood_mm=args.neighbourhood,
                                        frame=args.frame, up=args.up or "auto")
    mesh = export_mesh(surface, table=table, maps=surface_maps(args))
    asset = build_gltf(table, mesh, curvature_mode=args.curvature)
    if args.mesh is not None and not args.quiet:
        print_mesh_report(str(args.mesh), mesh)
        say(f"{args.mesh}: up axis: {mesh.info.get('up')} ({mesh.info.get('up_reason')})", err=True)
    out = write_gltf(asset, args.output)
    if args.materialx is not None:
        from ..export.materialx import write_materialx

        write_materialx(asset.fallback, args.materialx, material=str(table.attrs.get("material") or "fabric"),
                        source=Path(args.file).name)
    if not args.quiet:
        fit, err = asset.fallback, asset.encoding_error
        say(f"{out}: written ({out.stat().st_size:,} bytes; {mesh.n_vertices:,} vertices, "
            f"{mesh.faces.shape[0]:,} triangles)", err=True)
        say(f"table: 16-bit lookup texture, largest error {err['maxAbsoluteOverRange']:.2g} of each channel's range "
            f"(median relative {err['medianRelative']:.2g}); fallback material: relative RMS error "
            f"{fit.relative_rms_error:.1%} against the flat BRDF", err=True)
        if args.materialx is not None:
            say(f"{args.materialx}: written (MaterialX standard_surface; the curvature dependence is not "
                "expressible there)", err=True)
    return 0
