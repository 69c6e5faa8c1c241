"""The viewer as files: the page, its script and the assets, for serving or a static folder.

:func:`viewer_files` builds every file of the viewer in memory:

- ``index.html``, ``lookup.js`` (the GLSL lookup, shared with the glTF
  renderer) and ``viewer.js``: the page (package data, ``assets/``);
- ``data.js``: ``window.CDBRDF_VIEWER_DATA``, every asset's JSON header and
  its binary blob in base64, loaded by a ``<script>`` tag, so that the page
  opens from ``file://`` (where a browser refuses ``fetch()`` of local files)
  as well as from any static web host;
- ``assets/NAME.json`` and ``assets/NAME.bin``: the same assets as plain
  files (header and little-endian blob, :mod:`cdbrdf.view.asset`) for other
  tools; the page does not read them.

:func:`export_viewer` writes them as an owned output folder, atomically
(:func:`cdbrdf.outputs.output_folder`: built beside the destination and
swapped in whole; a user's folder is refused); :func:`write_viewer` writes
them into a folder being built (the demo's).
"""

from __future__ import annotations

import base64
import json
import logging
import re
from collections.abc import Mapping, Sequence
from importlib import resources
from os import PathLike
from pathlib import Path
from typing import Any

import numpy as np

from ..btf import CDBTF
from ..errors import OptionError
from ..mesh import SineSheet
from .asset import Asset, mesh_asset, table_asset
from .btf_asset import btf_asset

__all__ = [
    "EXPORT_MAKER",
    "EXPORT_SIGNATURE",
    "MAX_TABLES",
    "PAGE_FILES",
    "default_meshes",
    "drape_entry",
    "export_viewer",
    "viewer_files",
    "write_viewer",
]

_LOG = logging.getLogger(__name__)

#: The maker an export's owner mark names (:func:`cdbrdf.outputs.output_folder`): only an export replaces one.
EXPORT_MAKER = "view --export"

#: Files every export holds (an export marked before makers were recorded is recognised by them).
EXPORT_SIGNATURE: tuple[str, ...] = ("index.html", "data.js")

#: Tables the viewer shows side by side at most.
MAX_TABLES = 2

#: The page's own files (package data under ``cdbrdf/view/assets``) and their names in the folder.
PAGE_FILES: Mapping[str, str] = {"viewer.html": "index.html", "lookup.js": "lookup.js", "viewer.js": "viewer.js"}

#: Vertices along each side of the draped cloth shown in the viewer.
DRAPE_RESOLUTION = 101


def default_meshes(*, drape: Any = None) -> dict[str, Any]:
    """The meshes every viewer shows: the draped cloth the demo renders (curvature from the mesh).

    Parameters
    ----------
    drape
        An already prepared draped-cloth mesh (the demo has one), else it is
        built and prepared here (:func:`cdbrdf.mesh.prepare_mesh`).

    Returns
    -------
    dict
        ``{"drape": prepared Mesh}``.
    """
    if drape is None:
        from ..mesh import DrapedCloth, draped_cloth_mesh, prepare_mesh

        drape = prepare_mesh(draped_cloth_mesh(DrapedCloth(resolution=DRAPE_RESOLUTION)))
    return {"drape": drape}


def drape_entry(drape: Any = None) -> tuple[str, Any, tuple[float, float]]:
    """The draped cloth as a :func:`viewer_files` mesh entry: label, mesh, mm of fabric per UV unit.

    The cloth's UVs run linearly over its plan, 0 to 1 across its size (as
    the sine sheet's), so one UV unit is the plan's size in mm along x and
    y: a CD-BTF shows its weave there at true size (stretched a little on
    the steep slopes of the folds, where the plan is shorter than the cloth).

    Parameters
    ----------
    drape
        The prepared draped-cloth mesh (default: :func:`default_meshes`'s).

    Returns
    -------
    tuple
        ``("draped cloth", mesh, (su, sv))``.
    """
    from ..mesh.units import parse_units

    m = default_meshes(drape=drape)["drape"]
    scale = float(parse_units(m.metadata.get("units", "mm")).mm_per_unit)
    span = np.ptp(np.asarray(m.vertices, dtype=np.float64)[:, :2], axis=0) * scale
    uv = np.ptp(np.asarray(m.uv, dtype=np.float64), axis=0) if m.uv is not None else np.zeros(2)
    su, sv = (float(s / u) if u > 0 else 1.0 for s, u in zip(span, uv, strict=True))
    return "draped cloth", m, (su, sv)


def _label(name: str) -> str:
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", name)[:64] or "asset"


def viewer_files(
    tables: Sequence[tuple[str, Any]],
    *,
    meshes: Mapping[str, tuple[Any, ...]] | None = None,
    precision: str = "auto",
    exposure_ev: float | None = None,
    max_rank: int | None = None,
    open_on: str | None = None,
) -> dict[str, bytes]:
    """Every file of the viewer, by relative path.

    Parameters
    ----------
    tables
        ``(label, CDBRDF or CDBTF)`` pairs: one table, or two shown side by
        side. A :class:`cdbrdf.CDBTF` is shown with its weave on the sine
        sheet and the stand (:func:`cdbrdf.view.btf_asset.btf_asset`).
    meshes
        ``{key: (label, prepared Mesh)}`` or ``{key: (label, prepared Mesh,
        uv_scale_mm)}`` (mm of fabric per UV unit, one number or ``(su, sv)``;
        default 1: the UVs in mm, as the renderer's ``uv_scale``): a CD-BTF
        shows its weave on a mesh with UVs, its tile mean on one without; a
        mesh with a curvature map (``metadata["curvature_map"]``) shows its
        wrinkles (:func:`cdbrdf.view.asset.mesh_asset`).
        Default: the draped cloth (:func:`drape_entry`). The sine sheet and
        the stand are drawn by the shader and need no mesh.
    precision
        Texture precision (:data:`cdbrdf.view.asset.PRECISIONS`), of the
        tables and the curvature maps.
    exposure_ev
        The page's initial exposure, stops (default: from the first table).
    max_rank
        For a CD-BTF: use at most this many leading components (default:
        all that fit the GPU's guaranteed texture size).
    open_on
        The key of ``meshes`` the page opens on, framed as ``cdbrdf render``
        frames it (default: the sine sheet).

    Returns
    -------
    dict
        The files' bytes by relative path (``index.html``, scripts, assets).

    Raises
    ------
    OptionError
        For no table or more than :data:`MAX_TABLES`, a bad ``uv_scale_mm``,
        an ``open_on`` that is not a key of ``meshes``.
    LimitError
        For a table too large for WebGL2's textures.
    """
    if not 1 <= len(tables) <= MAX_TABLES:
        raise OptionError(f"tables: the viewer shows 1 or {MAX_TABLES} tables side by side, got {len(tables)}")
    if meshes is None:
        meshes = {"drape": drape_entry()}
    assets: list[tuple[str, Asset]] = []
    for i, (label, table) in enumerate(tables):
        if isinstance(table, CDBTF):
            a = btf_asset(table, name=label, precision=precision, max_rank=max_rank)
        else:
            a = table_asset(table, name=label, precision=precision)
        assets.append((f"table-{i}", a))
    if open_on is not None and open_on not in meshes:
        raise OptionError(f"open_on: {open_on!r} is not one of the meshes ({', '.join(meshes) or 'none'})")
    mesh_assets = [(key, mesh_asset(e[1], name=e[0], uv_scale_mm=e[2] if len(e) > 2 else 1.0, precision=precision))
                   for key, e in meshes.items()]
    files: dict[str, bytes] = {}
    pkg = resources.files("cdbrdf.view") / "assets"
    for src, dst in PAGE_FILES.items():
        files[dst] = (pkg / src).read_bytes()

    def entry(a: Asset) -> dict[str, Any]:
        return {"header": a.header, "data": base64.b64encode(a.blob).decode("ascii")}

    sheet = SineSheet()
    data = {
        "tables": [entry(a) for _, a in assets],
        "meshes": {_label(k): entry(a) for k, a in mesh_assets},
        # the surfaces the shader draws, with the sizes the renderer uses (cdbrdf.mesh)
        "surfaces": {"sheet": {"amplitude_mm": sheet.amplitude_mm, "wavelength_mm": sheet.wavelength_mm,
                               "width_mm": sheet.width_mm, "depth_mm": sheet.depth_mm}},
        "options": {**({} if exposure_ev is None else {"exposure_ev": float(exposure_ev)}),
                    **({} if open_on is None else {"surface": _label(open_on)})},
    }
    files["data.js"] = ("window.CDBRDF_VIEWER_DATA = " + json.dumps(data, separators=(",", ":"), allow_nan=False)
                        + ";\n").encode("ascii")
    for key, a in assets + [(f"mesh-{_label(k)}", a) for k, a in mesh_assets]:
        files[f"assets/{key}.json"] = (json.dumps(a.header, indent=1, allow_nan=False) + "\n").encode("ascii")
        files[f"assets/{key}.bin"] = a.blob
    return files


def write_viewer(folder: str | PathLike[str], files: Mapping[str, bytes]) -> Path:
    """Write the viewer's files into a folder (created if missing).

    For a folder that is itself being built atomically (the demo's partial
    output folder); :func:`export_viewer` is the atomic, refusing writer.

    Parameters
    ----------
    folder
        The folder.
    files
        Its files by relative path (:func:`viewer_files`).

    Returns
    -------
    pathlib.Path
        ``folder/index.html``.
    """
    root = Path(folder)
    root.mkdir(parents=True, exist_ok=True)
    for rel, data in files.items():
        p = root / rel
        p.parent.mkdir(parents=True, exist_ok=True)
        p.write_bytes(data)
    return root / "index.html"


def export_viewer(dest: str | PathLike[str], files: Mapping[str, bytes]) -> Path:
    """Write the viewer as a self-contained static folder, atomically.

    The folder is built beside ``dest`` and swapped in only when complete
    (:func:`cdbrdf.outputs.output_folder`): an error leaves no half-written
    folder, an earlier export is replaced whole, and a folder cdbrdf did not
    write (or one with files added since) is refused with
    :class:`FileExistsError`, one that another command made (the demo's
    output, a simulated capture) with :class:`~cdbrdf.errors.OutputError`.

    Parameters
    ----------
    dest
        The folder.
    files
        Its files by relative path (:func:`viewer_files`).

    Returns
    -------
    pathlib.Path
        ``dest/index.html``.
    """
    from ..outputs import output_folder

    with output_folder(dest, maker=EXPORT_MAKER, signature=EXPORT_SIGNATURE) as tmp:
        write_viewer(tmp, files)
    _LOG.info("wrote the viewer to %s", dest)
    return Path(dest) / "index.html"
