"""What a mesh file says about itself: its length unit and up axis, and where that is written.

Before the geometry is asked (:func:`cdbrdf.mesh.detect_up`,
:func:`cdbrdf.mesh.units.infer_units`), a file's own statements decide, each
reported with its source:

- the format's specification: glTF is in metres with +Y up (glTF 2.0, 3.4);
- the header's comments: a line naming the unit (``# Units: metres``, Maya's
  ``# This file uses centimeters as units for non-parametric coordinates.``)
  or the up axis (``# Y-up``, ``comment up axis: Z``);
- the asset's family: a MakeHuman mesh (its header, or a ``.mhmat`` /
  ``.mhclo`` file of the same name beside it) is in MakeHuman's frame,
  decimetres with +Y up;
- the tool that wrote it, as a default only (a tool's export options can be
  changed): Blender's and Maya's OBJ exporters and 3ds Max's write Y up.
  The geometry decides before a tool's default; the format's convention
  comes last.

:func:`file_statements` returns them as the :class:`~cdbrdf.mesh.Mesh`
metadata keys ``"units"``, ``"units_source"``, ``"up"``, ``"up_source"`` and
``"up_default"`` (``(axis, why)``).
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

__all__ = ["file_statements", "header_comments", "UNIT_WORDS"]

#: Words for units in files' comments, and the unit (:data:`cdbrdf.mesh.UNITS_MM` name or mm per unit).
UNIT_WORDS: dict[str, str] = {
    "millimeter": "mm", "millimetre": "mm", "mm": "mm",
    "centimeter": "cm", "centimetre": "cm", "cm": "cm",
    "decimeter": "dm", "decimetre": "dm", "dm": "dm",
    "meter": "m", "metre": "m", "m": "m",
    "inch": "in", "inches": "in", "in": "in",
    "foot": "304.8", "feet": "304.8", "ft": "304.8",
}

_UNIT = (r"(millimet(?:er|re)s?|centimet(?:er|re)s?|decimet(?:er|re)s?|met(?:er|re)s?|inch(?:es)?|feet|foot"
         r"|mm|cm|dm|m|in|ft)")
_UNITS_RES = (
    re.compile(rf"\b{_UNIT}\s+as\s+(?:the\s+)?units?\b", re.I),  # Maya: "uses centimeters as units"
    re.compile(rf"\b(?:length\s+)?units?\b\s*(?:is|are|in|[:=])?\s*{_UNIT}\b", re.I),  # "Units: metres"
)
_UP_RES = (
    re.compile(r"(?<![\w-])([+-]?[xyz])[\s_-]?up\b", re.I),  # "Y-up", "+Z up", "Z_UP"
    re.compile(r"\bup[\s_-]?(?:axis|vector|direction)\s*(?:is|[:=])?\s*([+-]?[xyz])\b", re.I),  # "up axis: Z"
    re.compile(r"\bup\s*(?:is|[:=])\s*([+-]?[xyz])\b", re.I),  # "up: y"
)

#: Tools whose OBJ export is Y up by default: (the header's words, the phrase reported).
_TOOL_DEFAULTS: tuple[tuple[re.Pattern[str], str], ...] = (
    (re.compile(r"\bBlender\b.*\bOBJ\b", re.I), "Blender's OBJ exporter writes Y up by default"),
    (re.compile(r"uses \w+ as units for non-parametric coordinates", re.I), "Maya (which wrote it) is Y up by default"),
    (re.compile(r"\b3ds Max\b", re.I), "3ds Max's OBJ exporter writes Y up by default"),
)

_MAKEHUMAN = re.compile(r"\bmesh file for MakeHuman\b", re.I)


def header_comments(data: bytes, *, max_lines: int = 200) -> list[str]:
    """The comment lines (``#``) among the first lines of an OBJ or OFF file, without the ``#``.

    Parameters
    ----------
    data
        The file's bytes.
    max_lines
        How many lines are looked at.

    Returns
    -------
    list of str
        The comments.
    """
    head = data[: 1 << 16].decode("utf-8", "replace").splitlines()[:max_lines]
    return [ln.lstrip()[1:].strip() for ln in head if ln.lstrip().startswith("#")]


def _quote(line: str, start: int) -> str:
    """The words of a comment from a match on, for a message."""
    text = line[start:].strip()
    return repr(text if len(text) <= 60 else text[:57] + "...")


def _unit_in(line: str) -> tuple[str, str] | None:
    for rx in _UNITS_RES:
        m = rx.search(line)
        if m:
            word = m.group(1).lower()
            word = word[:-1] if word.endswith("s") and word not in ("inches",) and len(word) > 3 else word
            if word in UNIT_WORDS:
                return UNIT_WORDS[word], _quote(line, m.start())
    return None


def _up_in(line: str) -> tuple[str, str] | None:
    for rx in _UP_RES:
        m = rx.search(line)
        if m:
            return m.group(1).lower().lstrip("+"), _quote(line, m.start())
    return None


def file_statements(path: Path, fmt: str, comments: list[str]) -> dict[str, Any]:
    """The unit and up axis a mesh file states, with their sources (see the module's description).

    Parameters
    ----------
    path
        The file (for the files beside it and the messages).
    fmt
        Its format (:data:`cdbrdf.mesh.MESH_FORMATS` value).
    comments
        Its header's comments (OBJ, OFF: :func:`header_comments`; PLY: the
        ``comment`` lines that are not cdbrdf's).

    Returns
    -------
    dict
        Any of ``"units"``, ``"units_source"``, ``"up"``, ``"up_source"``,
        ``"up_default"``, and ``"notes"`` (an up axis stated that cdbrdf
        cannot use).
    """
    out: dict[str, Any] = {}
    if fmt in ("gltf", "glb"):
        return {"units": "m", "units_source": "glTF's unit (its specification)",
                "up": "y", "up_source": "glTF's specification (+Y up)"}
    beside = [p.name for p in (path.with_suffix(".mhmat"), path.with_suffix(".mhclo")) if p.is_file()]
    if fmt == "obj" and (beside or any(_MAKEHUMAN.search(c) for c in comments)):
        why = f"{beside[0]} beside it" if beside else "its header"
        return {"units": "dm", "units_source": f"MakeHuman's unit ({why})",
                "up": "y", "up_source": f"MakeHuman's frame, +Y up ({why})"}
    for c in comments:
        unit = _unit_in(c)
        if unit is not None and "units" not in out:
            out["units"], out["units_source"] = unit[0], f"the file's header: {unit[1]}"
        up = _up_in(c)
        if up is not None and "up" not in out and "notes" not in out:
            if up[0] in ("y", "z"):
                out["up"], out["up_source"] = up[0], f"the file's header: {up[1]}"
            else:
                out["notes"] = [f"the file's header says the up axis is {up[0]} ({up[1]}); cdbrdf turns y or z "
                                "up only: the geometry decides (--up overrides)"]
    if fmt == "obj" and "up" not in out:
        for rx, why in _TOOL_DEFAULTS:
            if any(rx.search(c) for c in comments):
                out["up_default"] = ("y", why)
                break
    return out
