"""The options of the maps laid on a mesh by its UVs, shared by ``cdbrdf render`` and ``cdbrdf view``.

``--uv-scale SU[,SV]`` (mm per UV unit, of the maps and a CD-BTF),
``--normal-map``, ``--height-map`` with ``--height-scale``, ``--hires-mesh``,
``--map-size`` and ``--bake``: parsed here once, turned into one
:class:`cdbrdf.mesh.SurfaceMaps` by :func:`surface_maps`.
"""

from __future__ import annotations

import argparse
from typing import Any

__all__ = ["MAP_OPTIONS", "add_uv_scale", "add_map_options", "uv_scale_pair", "surface_maps"]

#: The destinations of the options :func:`add_map_options` adds (default None: not given).
MAP_OPTIONS: tuple[str, ...] = ("uv_scale", "normal_map", "normal_map_convention", "height_map", "height_scale",
                                "hires_mesh", "map_size", "bake")

_IMAGES = (".png", ".tif", ".tiff", ".exr")


def add_uv_scale(group: Any, *, help: str) -> None:  # noqa: A002 - argparse's own keyword
    """``--uv-scale SU[,SV]``: one or two numbers of mm per UV unit (:data:`cdbrdf.mesh.maps.UV_SCALE_RANGE_MM`)."""
    from ..mesh.maps import UV_SCALE_RANGE_MM as R
    from ._args import float_list

    group.add_argument("--uv-scale", type=float_list(R.lo, R.hi, lo_open=R.lo_open, min_len=1, max_len=2,
                                                     example="10,6", unit=R.unit),
                       default=None, metavar="SU[,SV]", help=help)


def uv_scale_pair(args: argparse.Namespace) -> tuple[float, float] | None:
    """``--uv-scale`` as ``(su, sv)`` (one number for both), or None."""
    if getattr(args, "uv_scale", None) is None:
        return None
    su = float(args.uv_scale[0])
    return su, float(args.uv_scale[1]) if len(args.uv_scale) > 1 else su


def add_map_options(group: Any) -> None:
    """The map options of a command that renders a mesh (see the module's description)."""
    from ..mesh import BAKES, NORMAL_MAP_CONVENTIONS
    from ..mesh.maps import HEIGHT_SCALE_RANGE_MM, MAP_SIZE_RANGE_MM
    from ._args import existing_file, float_list, in_range, mesh_file

    add_uv_scale(group, help="mm per UV unit of --mesh, for its maps and a CD-BTF's texels (default: detected: "
                 "the unit of UVs that are lengths, as a CAD tool's panels, else the median 3-D length per UV "
                 "length of the edges; the sine sheet: its size)")
    maps = group.add_mutually_exclusive_group()
    maps.add_argument("--normal-map", metavar="FILE", type=existing_file(*_IMAGES), default=None,
                      help="a tangent-space normal map of --mesh: its wrinkles shade and their curvature is looked "
                      "up per shading point (default: the MTL's norm/bump/disp or the glTF's normalTexture)")
    maps.add_argument("--height-map", metavar="FILE", type=existing_file(*_IMAGES), default=None,
                      help="a height (bump, displacement) map of --mesh, with --height-scale")
    maps.add_argument("--hires-mesh", metavar="MESH", type=mesh_file(), default=None,
                      help="a high-resolution version of --mesh (same unit and place): its curvature is baked "
                      "onto --mesh's UVs, signed, in 1/mm")
    group.add_argument("--normal-map-convention", choices=NORMAL_MAP_CONVENTIONS, default=None,
                       help="green channel of the normal map: opengl (up: Blender, glTF; default) or directx")
    group.add_argument("--height-scale", type=in_range(HEIGHT_SCALE_RANGE_MM), default=None,
                       metavar="MM", help="mm per unit of the height map's values (8/16-bit: full code = 1; "
                       "default: the MTL's -bm in the mesh's unit)")
    group.add_argument("--map-size", type=float_list(MAP_SIZE_RANGE_MM.lo, MAP_SIZE_RANGE_MM.hi,
                                                     lo_open=MAP_SIZE_RANGE_MM.lo_open, min_len=1, max_len=2,
                                                     example="100", unit=MAP_SIZE_RANGE_MM.unit),
                       default=None, metavar="MM[,MM]",
                       help="the size one repeat of the normal or height map covers on the cloth, mm (default: "
                       "the file's texture transform, else one repeat per UV unit)")
    group.add_argument("--bake", choices=BAKES, default=None,
                       help="texel: the maps looked up per shading point (default); vertex: their curvature "
                       "sampled at the mesh's vertices (only as fine as the mesh; they do not shade)")


def surface_maps(args: argparse.Namespace) -> Any:
    """The :class:`cdbrdf.mesh.SurfaceMaps` of the options given, or None when none is."""
    from ..mesh import SurfaceMaps

    if all(getattr(args, k, None) is None for k in MAP_OPTIONS):
        return None
    size = None if args.map_size is None else (float(args.map_size[0]), float(args.map_size[-1]))
    return SurfaceMaps(normal_map=args.normal_map, normal_map_convention=args.normal_map_convention or "opengl",
                       height_map=args.height_map, height_scale_mm=args.height_scale, hires_mesh=args.hires_mesh,
                       uv_scale=uv_scale_pair(args), map_size_mm=size, bake=args.bake or "texel")
