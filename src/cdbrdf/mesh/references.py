"""The files a mesh file pulls in: an OBJ's material libraries and their maps, a glTF's buffers and images.

Every one of them is an input of the run that reads the mesh, whoever
opens it (trimesh reads material libraries, buffers and images itself): the
output rule applies to them (``cdbrdf render --mesh shirt.obj -o
shirt_normal.png`` is refused when the shirt's MTL names that map,
:func:`cdbrdf.outputs.check_not_input`), and :func:`check_references`
refuses, before trimesh opens anything, a reference that is a FIFO, a
device, a folder, outside the file system (``file://``, ``http://``) or
larger than the limits.

- **OBJ**: each ``mtllib`` file (beside the OBJ), and in each of those every
  map statement (``map_Kd``, ``map_Bump``, ``bump``, ``disp``, ``norm``,
  ``decal``, ``refl``, ``map_*``), its options skipped;
- **glTF / GLB**: ``buffers[].uri`` and ``images[].uri`` that are not
  ``data:`` URIs, percent-decoded, relative to the file (glTF 2.0, 2.8).

A PLY, STL or OFF file pulls in nothing.
"""

from __future__ import annotations

import json
import re
import struct
from dataclasses import dataclass
from os import PathLike
from pathlib import Path
from urllib.parse import unquote, urlsplit

from ..errors import MeshError

__all__ = ["Reference", "referenced_files", "check_references"]

#: Largest material library read for its map statements (bytes).
_MTL_MAX_BYTES = 1 << 20

_MTLLIB = re.compile(rb"(?m)^[ \t]*mtllib[ \t]+([^\r\n]+?)[ \t]*$")
_MAP = re.compile(r"(?mi)^[ \t]*(map_\w+|bump|disp|decal|norm|refl)[ \t]+([^\r\n]+?)[ \t]*$")

#: Options of MTL map statements and how many values each takes (the MTL specification, Wavefront 1995).
_MAP_OPTIONS = {"-blendu": 1, "-blendv": 1, "-bm": 1, "-boost": 1, "-cc": 1, "-clamp": 1, "-imfchan": 1,
                "-mm": 2, "-o": 3, "-s": 3, "-t": 3, "-texres": 1, "-type": 1}


@dataclass(frozen=True)
class Reference:
    """One file a mesh file names.

    Parameters
    ----------
    path
        The file, resolved against the naming file's folder (may not exist).
    role
        What it is: ``"mtllib"``, the MTL statement (``"map_Kd"``, ``"norm"``...),
        ``"buffer"`` or ``"image"``.
    named_by
        The file that names it (the mesh, or its material library).
    options
        An MTL map statement's options before the file name, as written
        (``("-bm", "0.5", "-s", "2", "2", "1")``).
    """

    path: Path
    role: str
    named_by: Path
    options: tuple[str, ...] = ()


def _map_file(args: str) -> tuple[str, tuple[str, ...]]:
    """The file name of an MTL map statement's arguments, and its options."""
    words = args.split()
    i = 0
    while i < len(words) and words[i].lower() in _MAP_OPTIONS:
        most = _MAP_OPTIONS[words[i].lower()]
        i += 1
        if most == 1:  # -clamp on, -imfchan r, -type sphere, -bm 0.5: one word
            i += 1
            continue
        taken = 0  # -o u [v [w]], -mm base gain: the numbers that follow
        while taken < most and i < len(words) and _is_number(words[i]):
            i += 1
            taken += 1
    return " ".join(words[i:]), tuple(words[:i])


def _is_number(word: str) -> bool:
    try:
        float(word)
    except ValueError:
        return False
    return True


def _obj_references(p: Path, data: bytes) -> list[Reference]:
    from ..fsutil import read_regular

    refs: list[Reference] = []
    for m in _MTLLIB.finditer(data):
        text = m.group(1).decode("utf-8", "replace")
        whole = p.parent / text
        names = [text] if whole.exists() or " " not in text else text.split()
        for name in names:
            mtl = p.parent / name
            refs.append(Reference(mtl, "mtllib", p))
            try:
                lib = read_regular(mtl, max_bytes=_MTL_MAX_BYTES).decode("utf-8", "replace")
            except OSError:
                continue  # checked (and reported) by check_references
            for mm in _MAP.finditer(lib):
                name_, options = _map_file(mm.group(2))
                if name_:
                    refs.append(Reference(mtl.parent / name_.replace("\\", "/"), mm.group(1), mtl, options))
    return refs


def _gltf_json(p: Path, data: bytes) -> dict:
    if p.suffix.lower() == ".glb":
        if len(data) < 20 or data[:4] != b"glTF":
            raise MeshError(f"{p}: not a GLB file (no glTF header)")
        length, kind = struct.unpack_from("<I4s", data, 12)
        if kind != b"JSON" or 20 + length > len(data):
            raise MeshError(f"{p}: its first GLB chunk is not a complete JSON chunk")
        data = data[20:20 + length]
    try:
        doc = json.loads(data.decode("utf-8"))
    except (UnicodeDecodeError, ValueError, RecursionError) as exc:
        raise MeshError(f"{p}: cannot be read as glTF ({type(exc).__name__}: {str(exc)[:100]})") from None
    if not isinstance(doc, dict):
        raise MeshError(f"{p}: cannot be read as glTF (its JSON is not an object)")
    return doc


def _gltf_references(p: Path, data: bytes) -> list[Reference]:
    doc = _gltf_json(p, data)
    refs: list[Reference] = []
    for key, role in (("buffers", "buffer"), ("images", "image")):
        items = doc.get(key, [])
        if not isinstance(items, list):
            raise MeshError(f"{p}: glTF '{key}' is not an array")
        for i, item in enumerate(items):
            uri = item.get("uri") if isinstance(item, dict) else None
            if uri is None:
                continue
            if not isinstance(uri, str):
                raise MeshError(f"{p}: glTF {key}[{i}].uri is not a string")
            if uri.startswith("data:"):
                continue
            parts = urlsplit(uri)
            if parts.scheme or parts.netloc or uri.startswith("/"):
                raise MeshError(f"{p}: glTF {key}[{i}].uri {uri[:80]!r} is not a relative file name (only files "
                                "beside the glTF and data: URIs are read)")
            refs.append(Reference(p.parent / unquote(parts.path), role, p))
    return refs


def referenced_files(path: str | PathLike[str], data: bytes | None = None) -> list[Reference]:
    """Every file the mesh file ``path`` names (see the module's description).

    Parameters
    ----------
    path
        The mesh file.
    data
        Its bytes, when already read.

    Returns
    -------
    list of Reference
        In the order the file names them; names that do not exist included.

    Raises
    ------
    MeshError
        For a glTF whose JSON cannot be read or that names a URI which is
        not a relative file name.
    """
    p = Path(path)
    kind = p.suffix.lower()
    if kind not in (".obj", ".gltf", ".glb"):
        return []
    if data is None:
        from ..fsutil import read_regular
        from ..limits import limit

        try:
            # a glTF's JSON (a GLB's comes first) within the JSON limit; an OBJ whole (mtllib may be anywhere)
            data = read_regular(p, max_bytes=limit("json_bytes").value() + 20 if kind != ".obj" else 1 << 34)
        except OSError as exc:
            raise MeshError(f"{p}: cannot be read ({str(exc).removeprefix(f'{p}: ')})") from None
    return _obj_references(p, data) if kind == ".obj" else _gltf_references(p, data)


def check_references(path: str | PathLike[str], data: bytes | None = None) -> list[Reference]:
    """The files ``path`` names, each refused if reading it could hang or is not allowed.

    A reference that exists must be a regular file (not a FIFO, a device, a
    socket or a folder: :func:`cdbrdf.fsutil.check_regular`); a missing one
    is left to the reader (an OBJ's missing material library or map is
    skipped by it, a glTF's missing buffer refused).

    Parameters
    ----------
    path
        The mesh file.
    data
        Its bytes, when already read.

    Returns
    -------
    list of Reference
        As :func:`referenced_files` gives them.

    Raises
    ------
    MeshError
        ``"shirt.obj: its mtllib shirt.mtl is not a regular file (a FIFO) ..."``.
    """
    from ..fsutil import check_regular

    refs = referenced_files(path, data)
    for r in refs:
        try:
            check_regular(r.path)
        except FileNotFoundError:
            continue
        except OSError as exc:
            detail = str(exc).removeprefix(f"{r.path}: ")
            raise MeshError(f"{r.named_by}: its {r.role} {r.path} cannot be read ({detail})") from None
    return refs
