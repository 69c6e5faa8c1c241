"""Mitsuba XML scenes with the ``cdbrdf`` plug-in: loading, curvature units, the scene checks.

:func:`load_file` is :func:`mitsuba.load_file` for scenes that use
``<bsdf type="cdbrdf">``: it registers the plug-in, parses the file with
Mitsuba's own parser (``mitsuba.parser``: ``$name`` parameters, ``<default>``,
``<include>``, references), puts the scene file's folder first on Mitsuba's
file resolver (so relative file names, the table's ``filename`` included,
are found next to the scene, as Mitsuba does for meshes), and then, before
Mitsuba instantiates the objects:

- **curvature units**: a mesh's curvature attribute (``vertex_curvature`` or
  ``vertex_curvature_dir``, mm^-1 of the mesh in its file) is multiplied by
  ``m_file / (s * unit_mm)``, with ``s`` the uniform scale of the shape's
  ``to_world``, ``unit_mm`` the scene's unit (mm per scene unit, default 1)
  and ``m_file`` the mesh file's unit (mm per file unit) when its PLY header
  records one (``comment cdbrdf units cm``, as :func:`cdbrdf.mesh.write_ply`
  writes it), else 1 (the project's convention: lengths in mm unless a unit
  is given). The factor is given to the
  shape's BSDF as ``curvature_scale`` (times any ``curvature_scale`` the
  scene sets); shapes with different factors get their own copy of the BSDF.
  A non-uniform ``to_world`` scale would change the curvature differently in
  each direction: it is refused (bake the transform into the mesh and run
  ``cdbrdf curvature`` on the result);
- **two-sided**: a ``twosided`` wrapper around the plug-in is removed, with a
  warning (the plug-in is two-sided by itself and turns kappa's sign on the
  back, which the wrapper would not).

- **files and limits**: every file the scene names (``filename`` of
  meshes, textures, environment maps, tables, and ``<include>`` files,
  before Mitsuba parses them) must be a regular file: a FIFO would hang the
  load and ``/dev/zero`` fill the memory
  (:func:`cdbrdf.fsutil.check_regular`); every film must have a size of at
  least 1 x 1 within the ``render_pixels`` limit and every sampler at most
  :data:`cdbrdf.limits.MAX_SPP` samples per pixel, checked on the
  values the ``$name`` parameters give, before anything is allocated.

After instantiation :func:`cdbrdf.render.check_scene` runs (meshes need UVs
and the curvature attribute the BSDF reads).
"""

from __future__ import annotations

import logging
import math
import re
from dataclasses import dataclass, field
from os import PathLike
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import SceneError
from ..fsutil import check_regular, read_regular
from ._bsdf import PLUGIN_NAME
from ._units import ply_unit_mm, scene_factor, scene_units, uniform_scale
from .checks import check_scene
from .plugin import _APPLIED, mitsuba_message, register

__all__ = ["LoadReport", "load_file", "ply_unit_mm", "uniform_scale"]

_LOG = logging.getLogger(__name__)

#: Largest XML file read for its ``<include>`` elements, and how deep includes nest at most.
_MAX_XML_BYTES = 256 * 1024 * 1024
_MAX_INCLUDE_DEPTH = 16

#: Mitsuba's default film size (``hdrfilm`` without ``width`` or ``height``).
_DEFAULT_FILM = (768, 576)


@dataclass
class LoadReport:
    """What :func:`load_file` changed in the scene (also logged).

    Attributes
    ----------
    curvature_scales
        ``(shape, factor)`` for shapes whose curvature attribute is rescaled.
    unwrapped
        Shapes whose ``twosided`` wrapper around the plug-in was removed.
    files
        Every file the scene reads: the scene file, its includes and the
        files its objects name (resolved), for the output rule of
        :func:`cdbrdf.outputs.check_not_input`.
    """

    curvature_scales: list[tuple[str, float]] = field(default_factory=list)
    unwrapped: list[str] = field(default_factory=list)
    files: list[Path] = field(default_factory=list)


def _regular(path: Path, where: str) -> Path | None:
    """``path`` if it is a regular file, None if it does not exist (its reader says so), else a SceneError line.

    :func:`cdbrdf.fsutil.check_regular`: a FIFO or a device is never opened.
    """
    try:
        return check_regular(path)
    except FileNotFoundError:
        return None
    except OSError as exc:
        raise SceneError(f"{where}: {exc}") from None


def _substitute(text: str, values: dict[str, str]) -> str:
    return re.sub(r"\$([A-Za-z_][A-Za-z0-9_]*)", lambda m: values.get(m.group(1), m.group(0)), text)


def _check_includes(path: Path, params: dict[str, str], files: list[Path], depth: int = 0) -> None:
    """Check the files ``<include>`` elements name (recursively) before Mitsuba's parser opens them.

    The file must be well-formed XML: Mitsuba's parser accepts some files
    that are not (a duplicate attribute, an undefined entity), whose
    includes could not be checked. A relative include must exist beside the
    file that includes it: that is where Mitsuba looks first, and cdbrdf
    does not let it look further (its resolver would try the scene's folder,
    then the current folder).
    """
    import xml.etree.ElementTree as ET

    try:
        data = read_regular(path, max_bytes=_MAX_XML_BYTES)
    except OSError as exc:
        raise SceneError(f"{exc}") from None
    if len(data) > _MAX_XML_BYTES:
        raise SceneError(f"{path}: larger than {_MAX_XML_BYTES // 2**20} MiB; not read")
    try:
        root = ET.fromstring(data)
    except ET.ParseError as exc:
        raise SceneError(f"{path}: not well-formed XML ({exc}); cdbrdf reads only scenes whose includes it can "
                         "check") from None
    except (ValueError, RecursionError) as exc:
        raise SceneError(f"{path}: cannot be read as XML ({type(exc).__name__})") from None
    values = dict(params)
    for el in root.iter("default"):
        if el.get("name") and el.get("value") is not None:
            values.setdefault(str(el.get("name")), str(el.get("value")))
    for el in root.iter("include"):
        name = el.get("filename")
        if not name:
            continue
        inc = Path(_substitute(name, values))
        if not inc.is_absolute():
            inc = path.parent / inc
        where = f"{path}: <include filename={name!r}>"
        if _regular(inc, where) is None:
            raise SceneError(f"{where}: no such file beside {path.name} (includes are read from the including "
                             "file's folder only)")
        files.append(inc)
        if depth >= _MAX_INCLUDE_DEPTH:
            raise SceneError(f"{path}: includes nest deeper than {_MAX_INCLUDE_DEPTH} levels")
        _check_includes(inc, params, files, depth + 1)


def _check_nodes(state: Any, *, mi: Any) -> list[Path]:
    """The files a parsed scene names, each a regular file; its films and samplers within the limits.

    Returns the resolved files. Runs before Mitsuba instantiates anything,
    so neither a FIFO, nor ``/dev/zero``, nor a 20000 x 20000 film is ever
    opened or allocated.
    """
    import mitsuba.parser as mp

    from .. import limits
    from ..limits import MAX_SPP

    files: list[Path] = []
    for node in state.nodes:
        props = node.props
        if props is None:
            continue
        where = f"{mp.file_location(state, node)}: {props.plugin_name()}"
        for key in props.keys():
            if props.type(key) == mi.Properties.Type.String and (key == "filename" or key.endswith("_filename")):
                name = str(props[key])
                found = _regular(Path(str(mi.file_resolver().resolve(name))), f"{where} {key}={name!r}")
                if found is not None:
                    files.append(found)
        if node.type == mi.ObjectType.Film:
            w = int(props["width"]) if "width" in props else _DEFAULT_FILM[0]
            h = int(props["height"]) if "height" in props else _DEFAULT_FILM[1]
            if w < 1 or h < 1:
                raise SceneError(f"{where}: film size {w} x {h}; a film needs at least 1 x 1 pixels")
            limits.check("render_pixels", w * h, what=f"{where}: {w} x {h} film")
        if node.type == mi.ObjectType.Sampler and "sample_count" in props:
            n = int(props["sample_count"])
            if not 1 <= n <= MAX_SPP:
                raise SceneError(f"{where}: sample_count {n:,}; a render takes 1 to {MAX_SPP:,} samples per pixel")
    return files


def _references(props: Any, mi: Any) -> list[tuple[str, int]]:
    return [(k, int(props[k].index())) for k in props.keys()
            if props.type(k) == mi.Properties.Type.ResolvedReference]


def _is_cdbrdf(node: Any, mi: Any) -> bool:
    return node.type == mi.ObjectType.BSDF and node.props.plugin_name() == PLUGIN_NAME


def _prepare(state: Any, *, unit_mm: float | None, mi: Any) -> LoadReport:
    """The pass described in the module docstring, on a parsed, resolved scene."""
    import mitsuba.parser as mp

    report = LoadReport()
    nodes = state.nodes
    clones: dict[tuple[int, float], int] = {}
    originals: dict[int, Any] = {}
    n0 = len(nodes)
    for i in range(n0):
        node = nodes[i]
        if node.type != mi.ObjectType.Shape:
            continue
        props = node.props
        name = props.id() or f"{props.plugin_name()} #{i}"
        where = mp.file_location(state, node)
        for key, j in _references(props, mi):
            target = nodes[j]
            if target.type != mi.ObjectType.BSDF:
                continue
            if target.props.plugin_name() == "twosided":
                inner = [k2 for _, k2 in _references(target.props, mi) if _is_cdbrdf(nodes[k2], mi)]
                if inner:
                    props[key] = mi.Properties.ResolvedReference(inner[0])
                    j, target = inner[0], nodes[inner[0]]
                    report.unwrapped.append(name)
                    _LOG.warning("%s: shape %r: removed the twosided wrapper around the cdbrdf BSDF (the plug-in "
                                 "is two-sided by itself and changes the sign of kappa on the back)", where, name)
            if not _is_cdbrdf(target, mi):
                continue
            if unit_mm is not None:
                u_mm = unit_mm
            elif "unit" in target.props:
                u_mm = scene_units(target.props["unit"]).mm_per_unit
            else:
                u_mm = 1.0
            s = 1.0
            if "to_world" in props:
                s = uniform_scale(np.array(props["to_world"].matrix), what=f"{where}: shape {name!r} to_world")
            m_file = None
            if props.plugin_name() == "ply" and "filename" in props:
                m_file = ply_unit_mm(str(mi.file_resolver().resolve(str(props["filename"]))))
            factor = scene_factor(m_file=m_file, scale=s, unit_mm=u_mm)
            k = (j, round(factor, 12))
            if k not in clones:
                # the BSDF itself for its first factor, a copy of it as it was for each other one
                first = j not in originals
                if first:
                    originals[j] = mp.SceneNode(target)
                c = target if first else mp.SceneNode(originals[j])
                base = float(c.props["curvature_scale"]) if "curvature_scale" in c.props else 1.0
                c.props["curvature_scale"] = base * factor
                c.props["unit"] = float(u_mm)
                c.props[_APPLIED] = True
                if not first:
                    nodes.append(c)
                clones[k] = j if first else len(nodes) - 1
            props[key] = mi.Properties.ResolvedReference(clones[k])
            if abs(factor - 1.0) <= 1e-12:
                continue
            report.curvature_scales.append((name, factor))
            _LOG.info("%s: shape %r: curvature attribute x %.6g (to_world scale %.6g, file unit %s mm, scene "
                      "unit %.6g mm)", where, name, factor, s, "1 (assumed)" if m_file is None else f"{m_file:g}",
                      u_mm)
    for node in nodes:  # the plug-in's other instances (used by no shape): loaded by cdbrdf too
        if _is_cdbrdf(node, mi) and _APPLIED not in node.props:
            node.props[_APPLIED] = False
    return report


def load_file(path: str | PathLike[str], *, variables: dict[str, Any] | None = None, unit_mm: float | None = None,
              check: bool = True, optimize: bool = True, report: LoadReport | None = None) -> Any:
    """Load a Mitsuba XML file (a scene or one object) with the ``cdbrdf`` plug-in.

    Parameters
    ----------
    path
        The XML file.
    variables
        Values of the file's ``$name`` parameters (Mitsuba's ``-D name=value``).
    unit_mm
        Millimetres per scene unit (see the module docstring); default: the
        ``unit`` of each ``cdbrdf`` BSDF, else 1 (mm).
    check
        Run :func:`cdbrdf.render.check_scene` on a loaded scene.
    optimize
        Let Mitsuba merge equivalent objects and meshes (as ``mitsuba.load_file``).
    report
        Filled with what was changed (curvature scales, removed wrappers).

    Returns
    -------
    mitsuba.Scene or mitsuba.Object
        What the file describes, loaded in the active variant.

    Raises
    ------
    SceneError
        For a missing or invalid file, an unused or undefined parameter, a
        non-uniform ``to_world`` on a shape with the plug-in, a file named by
        the scene that is not a regular file, a film of size 0 or a sampler
        of more than :data:`cdbrdf.limits.MAX_SPP` samples, or a
        failed check.
    LimitError
        For a film larger than the ``render_pixels`` limit.
    """
    import mitsuba
    import mitsuba.parser as mp


    mi: Any = mitsuba
    p = Path(path)
    try:
        check_regular(p)
    except FileNotFoundError:
        raise SceneError(f"{p}: no such scene file") from None
    except OSError as exc:
        raise SceneError(f"scene file {exc}") from None
    if unit_mm is not None and not (math.isfinite(unit_mm) and unit_mm > 0):
        raise SceneError(f"unit_mm: must be a positive number of millimetres per scene unit, got {unit_mm}")
    register()
    params = {str(k): str(v) for k, v in (variables or {}).items()}
    config = mp.ParserConfig(str(mi.variant()))
    config.merge_equivalent = optimize
    config.merge_meshes = optimize
    backup = mi.file_resolver()
    fs = mi.FileResolver(backup)
    fs.prepend(str(p.parent.resolve()))
    mi.set_file_resolver(fs)
    try:
        files = [p]
        _check_includes(p, params, files)
        try:
            state = mp.parse_file(config, str(p), **params)
            mp.transform_upgrade(config, state)
            mp.transform_resolve(config, state)
        except RuntimeError as exc:
            raise SceneError(f"{p}: {mitsuba_message(exc)}") from None
        files += _check_nodes(state, mi=mi)
        rep = _prepare(state, unit_mm=None if unit_mm is None else float(unit_mm), mi=mi)
        try:
            if optimize:
                mp.transform_merge_equivalent(config, state)
                mp.transform_merge_meshes(config, state)
            obj = mp.instantiate(config, state)
        except RuntimeError as exc:
            raise SceneError(f"{p}: {mitsuba_message(exc)}") from None
    finally:
        mi.set_file_resolver(backup)
    if report is not None:
        report.curvature_scales.extend(rep.curvature_scales)
        report.unwrapped.extend(rep.unwrapped)
        report.files.extend(files)
    if check and isinstance(obj, mi.Scene):
        check_scene(obj)
    return obj
