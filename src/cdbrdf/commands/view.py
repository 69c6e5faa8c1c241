"""``cdbrdf view FILE [FILE2] [--mesh MESH [maps]] [--export DIR]``: the interactive viewer in the browser.

With ``--mesh`` the page opens on the mesh, framed as ``cdbrdf render``
frames it, and takes the same maps (``--normal-map``, ``--height-map``,
``--hires-mesh``, ``--uv-scale``, ...: :mod:`cdbrdf.commands._maps`, the
same rules and notes), looked up per fragment.
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ._text import say

if TYPE_CHECKING:
    from ..mesh import Mesh

__all__ = ["register", "run"]


def _grid(text: str) -> tuple[float, float, int | None]:
    from ..errors import OptionError
    from ..view.asset import parse_grid

    try:
        return parse_grid(text)
    except OptionError as exc:
        raise argparse.ArgumentTypeError(str(exc).removeprefix("grid: ")) from None


def register(sub: argparse._SubParsersAction) -> None:
    from ..mesh import MESH_FORMATS
    from ..view.export import EXPORT_MAKER, EXPORT_SIGNATURE
    from ._args import existing_file, int_range, keyword, mesh_file, output_folder
    from ._maps import add_map_options
    from .curvature import mesh_options

    p = sub.add_parser(
        "view",
        help="open a table in the interactive viewer (3-D surfaces, BRDF/CDBRDF, mosaic) in the browser",
        description=(
            "Serve the interactive viewer of one table, or two side by side, on 127.0.0.1 and print "
            "its address (the browser opens when there is one): the sine sheet with a bend slider, "
            "a cylinder stand, a draped cloth and your own mesh under a light you drag, the plain "
            "BRDF against the CDBRDF, the Fig. 7 mosaic and a polar slice. With --export DIR the "
            "same viewer is written as a static folder that opens from disk or any web host. "
            "Ctrl-C stops the server."
        ),
        epilog="examples: cdbrdf view denim.h5 shot.h5 --mesh shirt.obj --units cm; "
        "cdbrdf view shot.h5 --mesh quad.obj --normal-map wrinkles.png --uv-scale 100",
    )
    p.add_argument("files", metavar="FILE", nargs="+", type=existing_file(),
                   help="a CDBRDF or CD-BTF file (.h5), a second one shown side by side; or a glTF asset (.glb) "
                   "written by cdbrdf export, shown by the glTF renderer (three.js)")
    p.add_argument("--export", metavar="DIR", type=output_folder(maker=EXPORT_MAKER, signature=EXPORT_SIGNATURE),
                   help="write the viewer as a static folder DIR instead of serving it (replaced whole "
                   "only if it holds an earlier export of the viewer and nothing added to it)")
    p.add_argument("--port", type=int_range(1, 65535), default=0, metavar="N",
                   help="TCP port on 127.0.0.1 (default: a free one)")
    p.add_argument("--no-browser", dest="browser", action="store_false", help="do not open a browser")
    p.add_argument("--mesh", type=mesh_file(), metavar="MESH",
                   help=f"your own mesh ({', '.join(MESH_FORMATS)}; repaired, its curvature computed in "
                   "1/mm from --units unless the file has it, e.g. one written by cdbrdf curvature)")
    mesh_options(p, up_default="auto")
    p.add_argument("--grid", type=_grid, metavar="THETA_STEP,PHI_STEP[,N_KAPPA]",
                   help="resample the tables onto a regular grid first (degrees; e.g. 15,30), for a table "
                   "too large for the GPU's textures")
    p.add_argument("--rank", type=int_range(0, 100000), metavar="N",
                   help="for a CD-BTF: use at most its N leading components (default: all that fit the GPU's "
                   "guaranteed texture size; fewer draw faster)")
    add_map_options(p.add_argument_group("maps laid on --mesh by its UVs, as cdbrdf render lays them "
                                         "(docs/viewer.md, \"Maps\")"))
    p.add_argument("--precision", type=keyword(("auto", "float32", "float16")), default="auto",
                   help="texture precision of the tables and a curvature map: auto (float16 only for very large "
                   "tables; maps float32), float32 or float16")
    p.set_defaults(func=run)


def _browser_available() -> bool:
    if sys.platform.startswith("linux") and not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
        return False
    import webbrowser

    try:
        webbrowser.get()
    except webbrowser.Error:
        return False
    return True


def _user_mesh(args: argparse.Namespace, table: object, btf: bool) -> tuple[Mesh, tuple[float, float]]:
    """``--mesh`` prepared as ``cdbrdf render`` prepares it (its maps too), in the viewer's z-up frame; reported.

    Returns the mesh and the UV scale of a CD-BTF on it (the maps' one, as the renderer's).
    """
    from ..mesh import MeshSurface, has_own_uv, mesh_uv_scale, read_mesh, z_up_mesh
    from ._maps import surface_maps
    from ._progress import ProgressBars
    from .curvature import LARGE_MESH_FACES, print_mesh_report

    source = read_mesh(args.mesh)
    surface = MeshSurface(source, units=args.units, neighbourhood_mm=args.neighbourhood, frame=args.frame,
                          up=args.up)
    big = source.faces.shape[0] >= LARGE_MESH_FACES
    with ProgressBars(quiet=args.quiet or not big, unit="vtx") as bars:
        mesh = surface.prepare(table=table, maps=surface_maps(args), progress=bars.callback("curvature"))
    world, up, why = z_up_mesh(mesh, surface.up)
    scale = (1.0, 1.0)
    if btf and has_own_uv(world):
        uvs = mesh_uv_scale(world)
        if world.metadata.get("uv_scale") is None:
            world.metadata["notes"] = [*world.metadata.get("notes", []), f"UV scale: {uvs}"]
        scale = uvs.pair
    if not args.quiet:
        print_mesh_report(str(args.mesh), world)
        say(f"{args.mesh}: up axis: {up} ({why})", err=True)
    return world, scale


def _btf(args: argparse.Namespace, path: str, t: Any) -> Any:
    """A CD-BTF read from ``path``, checked; says on standard error when the viewer uses fewer components."""
    from ..errors import OptionError
    from ..view.btf_asset import btf_rank_that_fits

    name = Path(path).name
    if args.grid is not None:
        raise OptionError(f"--grid: {name} is a CD-BTF, which the viewer shows on its own grid "
                          "(use --rank N for fewer components)")
    fits = btf_rank_that_fits(t)
    used = min(fits, t.rank if args.rank is None else args.rank)
    if used < t.rank and not args.quiet:
        why = "--rank" if args.rank is not None and args.rank <= fits else "all that fit WebGL2's textures"
        say(f"{name}: CD-BTF of rank {t.rank}: the viewer uses its leading {used} components ({why})", err=True)
    return t


#: Options of the table viewer that the glTF renderer does not take.
_TABLE_VIEWER_ONLY = ("mesh", "grid", "rank", "uv_scale", "units", "neighbourhood", "frame")


def _gltf_files(args: argparse.Namespace) -> tuple[str, dict[str, bytes]]:
    """``cdbrdf view x.glb``: the glTF renderer's files (:mod:`cdbrdf.view.gltf_page`)."""
    from ..errors import FormatError, OptionError
    from ..fsutil import read_regular
    from ..gltf_table import MAX_GLTF_BYTES
    from ..table import load
    from ..view.gltf_page import gltf_viewer_files

    if len(args.files) != 1:
        raise OptionError("FILE: the glTF renderer shows one asset (.glb) at a time")
    from ._maps import MAP_OPTIONS

    given = [o for o in (*_TABLE_VIEWER_ONLY, *MAP_OPTIONS) if getattr(args, o, None) not in (None, False)]
    if args.up != "auto":
        given.append("up")
    if args.precision != "auto":
        given.append("precision")
    if given:
        raise OptionError(f"--{given[0].replace('_', '-')}: not for a glTF asset (its mesh, curvature and table "
                          "are in the file)")
    path = Path(args.files[0])
    if path.suffix.lower() != ".glb":
        raise OptionError(f"{path}: the glTF renderer opens binary glTF (.glb); write one with cdbrdf export -o X.glb")
    glb = read_regular(path, max_bytes=MAX_GLTF_BYTES)
    if glb[:4] != b"glTF":
        raise FormatError(f"{path}: not a binary glTF file")
    load(path)  # refuses a file without the extension, or a damaged one, in one line
    return path.name, gltf_viewer_files(glb, name=path.name)


def run(args: argparse.Namespace) -> int:
    from ..btf import CDBTF
    from ..errors import OptionError
    from ..gltf_table import is_gltf
    from ..mesh import has_own_uv
    from ..sources import open_source
    from ..view.asset import resample
    from ..view.export import MAX_TABLES, drape_entry, viewer_files
    from ._maps import MAP_OPTIONS

    if any(is_gltf(f) for f in args.files):
        name, files = _gltf_files(args)
        return _publish(args, [name], files)
    if len(args.files) > MAX_TABLES:
        raise OptionError(f"FILE: the viewer shows at most {MAX_TABLES} tables side by side, got {len(args.files)}")
    if args.export:
        from ..outputs import check_output_folder
        from ..view.export import EXPORT_MAKER, EXPORT_SIGNATURE

        check_output_folder(args.export, maker=EXPORT_MAKER, signature=EXPORT_SIGNATURE)  # before any work
    given = [k for k in MAP_OPTIONS if getattr(args, k) is not None]
    if given and not args.mesh:
        raise OptionError(f"--{given[0].replace('_', '-')}: only for --mesh MESH (the sheet's and the stand's bends "
                          "are their geometry; the draped cloth's UVs span it)")
    tables: list[tuple[str, Any]] = []
    for f in args.files:
        source = open_source(f)
        if source.is_btf:
            tables.append((Path(f).name, _btf(args, f, source.table)))
            continue
        t = source.table
        if args.grid is not None:
            ts, ps, nk = args.grid
            t = resample(t, theta_step_deg=ts, phi_step_deg=ps, n_kappa=nk)
        tables.append((Path(f).name, t))
    meshes: dict[str, tuple[Any, ...]] = {"drape": drape_entry()}
    if args.mesh:
        first = tables[0][1]
        btf = any(isinstance(t, CDBTF) for _, t in tables)
        user, scale = _user_mesh(args, first.mean() if isinstance(first, CDBTF) else first, btf)
        meshes["user"] = (Path(args.mesh).name, user, scale)
        if any(isinstance(t, CDBTF) for _, t in tables) and not has_own_uv(user) and not args.quiet:
            say(f"{Path(args.mesh).name}: no UVs: the viewer shows the CD-BTF's tile mean on it", err=True)
    files = viewer_files(tables, meshes=meshes, precision=args.precision, max_rank=args.rank,
                         open_on="user" if args.mesh else None)
    return _publish(args, [n for n, _ in tables], files)


def _publish(args: argparse.Namespace, names: list[str], files: dict[str, bytes]) -> int:
    """Write the pages as a static folder (``--export``) or serve them until Ctrl-C."""
    from ..view.export import export_viewer

    if args.export:
        index = export_viewer(args.export, files)
        if not args.quiet:
            say(f"wrote {index} (open it in a browser; the folder works offline and on any static host)")
        return 0
    from ..view.server import ViewerServer

    server = ViewerServer(files, port=args.port)
    say(f"cdbrdf view: serving {', '.join(names)} at {server.url} (Ctrl-C stops)", flush=True)
    if args.browser and _browser_available():
        import webbrowser

        webbrowser.open(server.url)
    try:
        server.serve_forever()
    except KeyboardInterrupt:
        say("cdbrdf view: stopped", err=True)
    finally:
        server.close()
    return 0
