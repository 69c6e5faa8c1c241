"""The command line's one argument-validation layer: argparse ``type=`` factories.

Every option of every ``cdbrdf`` sub-command is parsed by one of the
factories below, so that a bad value is refused while the arguments are
parsed, before anything is read, computed or written. Each factory returns
a callable for ``add_argument(type=...)`` that raises
:class:`argparse.ArgumentTypeError` with a one-line message stating the
allowed values; argparse prefixes it with the option's name
(``argument --exposure: ...``) and :class:`cdbrdf.cli.Parser` prints it as
one line and exits with status 2.

A command adopts a factory with one line per option, e.g.::

    p.add_argument("--patch", type=int_range(1, 999), default=7)

The callables are also usable outside argparse (they raise
:class:`argparse.ArgumentTypeError`, a plain :class:`Exception`).

Path types carry a ``role`` (``"input"``, ``"output"`` for a file,
``"output_folder"``): :func:`guarded` reads the roles of a parsed command and
applies the one output rule of every command before it runs (no output is,
holds or lies inside an input; one run at a time writes an output).
"""

from __future__ import annotations

import argparse
import math
import os
import re
from collections.abc import Callable, Iterable, Iterator
from contextlib import ExitStack, contextmanager
from pathlib import Path
from typing import Any

__all__ = [
    "SEED_MAX",
    "finite_float",
    "int_range",
    "in_range",
    "float_list",
    "size_wxh",
    "square_size",
    "existing_file",
    "brdf_file",
    "partner_files",
    "input_path",
    "output_path",
    "output_file",
    "output_folder",
    "with_role",
    "mesh_file",
    "guarded",
    "seed",
    "name_or_index",
    "keyword",
]

#: Largest seed Mitsuba and numpy both accept (Mitsuba's seeds are 32-bit unsigned).
SEED_MAX = 2**32 - 1

_Type = Callable[[str], Any]


def _interval(lo: float | None, hi: float | None, lo_open: bool, hi_open: bool) -> str:
    """What a number must be, in words (the wording of :meth:`cdbrdf.ranges.Range.expect`)."""
    from ..ranges import Range

    return Range(lo, hi, lo_open, hi_open).expect()


#: Roles of path types (see :func:`guarded`).
ROLES = ("input", "output", "output_folder")


def _named(func: _Type, name: str, role: str | None = None) -> _Type:
    func.__name__ = name  # argparse names the type in some messages
    if role is not None:
        setattr(func, "role", role)  # noqa: B010 - an attribute functions do not declare
    return func


def _parse_float(text: str, expect: str) -> float:
    try:
        x = float(text)
    except (TypeError, ValueError):
        raise argparse.ArgumentTypeError(f"expected {expect}, got {text!r}") from None
    return x


def _check_float(x: float, text: str, lo: float | None, hi: float | None, lo_open: bool,
                 hi_open: bool, unit: str) -> float:
    ok = math.isfinite(x)
    if ok and lo is not None:
        ok = x > lo if lo_open else x >= lo
    if ok and hi is not None:
        ok = x < hi if hi_open else x <= hi
    if not ok:
        what = _interval(lo, hi, lo_open, hi_open) + (f" {unit}" if unit else "")
        raise argparse.ArgumentTypeError(f"expected {what}, got {text!r}")
    return x


def finite_float(
    lo: float | None = None,
    hi: float | None = None,
    *,
    lo_open: bool = False,
    hi_open: bool = False,
    unit: str = "",
) -> _Type:
    """A finite float in ``[lo, hi]`` (bounds optional, either end may be open).

    Parameters
    ----------
    lo, hi
        Bounds; ``None`` for none (the value must still be finite: ``nan`` and
        ``inf`` are always refused).
    lo_open, hi_open
        Exclude the bound itself (``lo=0, lo_open=True``: strictly positive).
    unit
        Unit named in the message (``"mm"``, ``"EV"``).

    Returns
    -------
    callable
        ``str -> float`` raising :class:`argparse.ArgumentTypeError`.
    """
    expect = _interval(lo, hi, lo_open, hi_open) + (f" {unit}" if unit else "")

    def parse(text: str) -> float:
        return _check_float(_parse_float(text, expect), text, lo, hi, lo_open, hi_open, unit)

    return _named(parse, "number")


def _parse_int(text: str, lo: int, hi: int) -> int:
    expect = f"an integer in [{lo}, {hi}]"
    t = str(text).strip()
    if not re.fullmatch(r"[+-]?\d{1,40}", t):
        raise argparse.ArgumentTypeError(f"expected {expect}, got {text!r}")
    v = int(t)
    if not lo <= v <= hi:
        raise argparse.ArgumentTypeError(f"expected {expect}, got {text!r}")
    return v


def int_range(lo: int, hi: int) -> _Type:
    """An integer in ``[lo, hi]`` (no fractions, no exponents).

    Returns
    -------
    callable
        ``str -> int`` raising :class:`argparse.ArgumentTypeError`.
    """
    if lo > hi:
        raise ValueError(f"int_range: lo {lo} > hi {hi}")

    def parse(text: str) -> int:
        return _parse_int(text, lo, hi)

    return _named(parse, "integer")


def in_range(rng: Any) -> _Type:
    """The option type of a library record's :class:`cdbrdf.ranges.Range`: the one owner of its range.

    Returns
    -------
    callable
        :func:`int_range` for whole numbers, else :func:`finite_float`.
    """
    if rng.integer:
        return int_range(int(rng.lo), int(rng.hi))
    return finite_float(rng.lo, rng.hi, lo_open=rng.lo_open, hi_open=rng.hi_open, unit=rng.unit)


def seed(hi: int = SEED_MAX) -> _Type:
    """A random seed: an integer in ``[0, hi]`` (default ``2**32 - 1``, Mitsuba's largest).

    Commands that derive further seeds by adding an offset pass a smaller ``hi``.
    """
    return _named(int_range(0, hi), "seed")


def float_list(
    lo: float | None = None,
    hi: float | None = None,
    *,
    lo_open: bool = False,
    hi_open: bool = False,
    min_len: int = 1,
    max_len: int = 64,
    sep: str = ",",
    unique: bool = False,
    unit: str = "",
    example: str = "",
) -> _Type:
    """Numbers separated by ``sep`` (``"-0.22,0,0.22"``), each a :func:`finite_float`.

    Parameters
    ----------
    lo, hi, lo_open, hi_open, unit
        Range of every number (see :func:`finite_float`).
    min_len, max_len
        How many numbers are allowed (``2, 2`` for a pair).
    sep
        Separator (``","``; ``"x"`` also accepted when ``sep="x"``, e.g. ``60x60``).
    unique
        Refuse repeated numbers.
    example
        Shown in the message (e.g. ``"45,0"``).

    Returns
    -------
    callable
        ``str -> list[float]`` raising :class:`argparse.ArgumentTypeError`.
    """
    count = f"{min_len}" if min_len == max_len else f"{min_len} to {max_len}"
    each = _interval(lo, hi, lo_open, hi_open) + (f" {unit}" if unit else "")
    shape = f"{count} number{'s' * (max_len != 1)} separated by {sep!r}" + (
        f" like {example}" if example else "")

    def parse(text: str) -> list[float]:
        parts = [p.strip() for p in str(text).split(sep)]
        if parts and parts[-1] == "" and len(parts) > 1:  # tolerate a trailing separator
            parts = parts[:-1]
        if not min_len <= len(parts) <= max_len or any(p == "" for p in parts):
            raise argparse.ArgumentTypeError(f"expected {shape}, got {text!r}")
        out = []
        for p in parts:
            x = _parse_float(p, shape)
            try:
                out.append(_check_float(x, p, lo, hi, lo_open, hi_open, unit))
            except argparse.ArgumentTypeError:
                raise argparse.ArgumentTypeError(
                    f"expected {shape}, each {each}; got {text!r}") from None
        if unique and len(set(out)) != len(out):
            raise argparse.ArgumentTypeError(f"expected distinct numbers, got {text!r}")
        return out

    return _named(parse, "list")


def _limit(name: str, amount: float, what: str) -> None:
    """:func:`cdbrdf.limits.check` as an :class:`argparse.ArgumentTypeError`."""
    from ..errors import LimitError
    from ..limits import check

    try:
        check(name, amount, what=what)
    except LimitError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def size_wxh(*, lo: int = 1, hi: int = 65536, limit: str = "render_pixels") -> _Type:
    """An image size ``WxH`` (or ``W,H``) of integers in ``[lo, hi]``, ``W*H`` within a limit.

    Parameters
    ----------
    lo, hi
        Range of each side in pixels.
    limit
        :mod:`cdbrdf.limits` name bounding ``W * H`` (default ``render_pixels``).

    Returns
    -------
    callable
        ``str -> tuple[int, int]`` raising :class:`argparse.ArgumentTypeError`.
    """

    def parse(text: str) -> tuple[int, int]:
        parts = str(text).lower().replace(",", "x").split("x")
        if len(parts) != 2:
            raise argparse.ArgumentTypeError(f"expected WxH like 512x384, got {text!r}")
        try:
            w, h = (_parse_int(p, lo, hi) for p in parts)
        except argparse.ArgumentTypeError:
            raise argparse.ArgumentTypeError(
                f"expected WxH like 512x384 with sides in [{lo}, {hi}] pixels, got {text!r}") from None
        _limit(limit, w * h, f"{w} x {h} image")
        return w, h

    return _named(parse, "size")


def square_size(*, lo: int = 8, hi: int = 65536, limit: str = "render_pixels") -> _Type:
    """A square image's side in pixels, in ``[lo, hi]``, its area within a limit."""
    side = int_range(lo, hi)

    def parse(text: str) -> int:
        n = side(text)
        _limit(limit, n * n, f"{n} x {n} image")
        return n

    return _named(parse, "size")


def _suffixes(kinds: Iterable[str]) -> tuple[str, ...]:
    return tuple(k.lower() if k.startswith(".") else f".{k.lower()}" for k in kinds)


def existing_file(*kinds: str) -> _Type:
    """A regular file that exists, with one of the suffixes ``kinds`` if given (an input).

    A folder, a FIFO, a device or a socket is refused
    (:func:`cdbrdf.fsutil.check_regular`: reading it could block or never end).

    Examples
    --------
    ``existing_file(".exr", ".hdr")`` for an environment map;
    ``existing_file()`` for any file.
    """
    suffixes = _suffixes(kinds)

    def parse(text: str) -> str:
        p = Path(text)
        if suffixes and p.suffix.lower() not in suffixes:
            got = repr(p.suffix) if p.suffix else "no suffix"
            raise argparse.ArgumentTypeError(
                f"{text}: expected a {' or '.join(suffixes)} file, got {got}")
        from ..fsutil import check_regular

        try:
            check_regular(p)
        except IsADirectoryError:
            raise argparse.ArgumentTypeError(f"{text}: is a folder, expected a file") from None
        except FileNotFoundError:
            raise argparse.ArgumentTypeError(f"{text}: no such file") from None
        except OSError as exc:
            raise argparse.ArgumentTypeError(str(exc)) from None
        return text

    return _named(parse, "file", "input")


def mesh_file() -> _Type:
    """A mesh file (:data:`cdbrdf.mesh.MESH_FORMATS`), an input with every file it pulls in.

    The material libraries, maps, buffers and images the mesh names
    (:func:`cdbrdf.mesh.referenced_files`) are inputs too: :func:`guarded`
    refuses an output over any of them.
    """
    from ..mesh import MESH_FORMATS

    base = existing_file(*MESH_FORMATS)

    def parse(text: str) -> str:
        return base(text)

    def pulls_in(path: str) -> list[str]:
        from ..mesh import referenced_files

        return [str(r.path) for r in referenced_files(path)]

    func = _named(parse, "mesh", "input")
    setattr(func, "pulls_in", pulls_in)  # noqa: B010 - an attribute functions do not declare
    return func


def brdf_file() -> _Type:
    """A BRDF file to import (an input), with the other file of a Neural-BRDF pair as an input too.

    A Neural-BRDF network is ``NAME.json`` + ``NAME.h5``
    (:func:`cdbrdf.importers.nbrdf.pair`): an output named as the partner of
    the file given would overwrite the network's other half, so it is an
    input for :func:`guarded` as well.
    """
    base = existing_file()

    def parse(text: str) -> str:
        return base(text)

    func = _named(parse, "file", "input")
    setattr(func, "pulls_in", partner_files)  # noqa: B010 - an attribute functions do not declare
    return func


def partner_files(path: str) -> list[str]:
    """The other file of a Neural-BRDF pair beside ``path``, if there is one (inputs for :func:`guarded`)."""
    from ..errors import FormatError
    from ..importers.nbrdf import pair

    try:
        return [str(q) for q in pair(path) if q != Path(path) and q.exists()]
    except (FormatError, OSError):
        return []


def with_role(func: _Type, role: str) -> _Type:
    """``func`` (an argparse type) marked as parsing a path of ``role`` (:data:`ROLES`) for :func:`guarded`."""
    if role not in ROLES:
        raise ValueError(f"role: {role!r} is not one of {', '.join(ROLES)}")
    return _named(func, getattr(func, "__name__", "path"), role)


def input_path() -> _Type:
    """A path the command reads and checks itself (an input for :func:`guarded`)."""

    def parse(text: str) -> str:
        return text

    return _named(parse, "path", "input")


def output_path() -> _Type:
    """A file the command writes and checks itself (an output for :func:`guarded`)."""

    def parse(text: str) -> str:
        return text

    return _named(parse, "path", "output")


def output_file(*kinds: str) -> _Type:
    """A file to write: suffix among ``kinds`` (if given), in an existing folder, not a folder.

    An existing destination must be a regular file (never a device such as
    ``/dev/null``, a FIFO or a socket: :func:`cdbrdf.fsutil.check_output_file`).
    """
    suffixes = _suffixes(kinds)

    def parse(text: str) -> str:
        p = Path(text)
        if suffixes and p.suffix.lower() not in suffixes:
            got = repr(p.suffix) if p.suffix else "no suffix"
            raise argparse.ArgumentTypeError(
                f"{text}: cannot write {got}; use {', '.join(suffixes)}")
        from ..fsutil import check_output_file

        try:
            check_output_file(text)  # a folder, a missing folder, a device or FIFO
        except OSError as exc:
            raise argparse.ArgumentTypeError(str(exc)) from None
        return text

    return _named(parse, "file", "output")


def output_folder(*, maker: str | None = None, signature: tuple[str, ...] = (), replaced: bool = True) -> _Type:
    """An output folder: one replaced whole (:func:`cdbrdf.outputs.check_output_folder`), or written into.

    Parameters
    ----------
    maker, signature
        The command that makes the folder and the files each of its folders
        holds (:func:`cdbrdf.outputs.output_folder`).
    replaced
        False for a folder files are written into (``cdbrdf plan``): not checked here.
    """

    def parse(text: str) -> str:
        if replaced:
            from ..errors import OutputError
            from ..outputs import check_output_folder

            try:
                check_output_folder(text, maker=maker, signature=signature)
            except (OSError, OutputError) as exc:
                raise argparse.ArgumentTypeError(str(exc)) from None
        return text

    return _named(parse, "folder", "output_folder")


def _values(value: Any) -> Iterator[str]:
    if isinstance(value, (list, tuple)):
        for v in value:
            yield from _values(v)
    elif isinstance(value, (str, os.PathLike)):
        yield os.fspath(value)


@contextmanager
def guarded(parser: argparse.ArgumentParser, args: argparse.Namespace) -> Iterator[None]:
    """Run a parsed command under the one output rule of every command.

    The paths of ``args`` whose option types carry a role (:data:`ROLES`)
    are its inputs and outputs. Before the command runs, an output that is,
    holds or lies inside an input is refused
    (:func:`cdbrdf.outputs.check_not_input`); then the lock of every output
    is held (:func:`cdbrdf.outputs.output_lock`) until the command returns,
    so a second run on the same output is refused at once.

    Raises
    ------
    cdbrdf.errors.OutputError
        One line naming the output and the input, or the run that holds it.
    """
    from ..outputs import check_not_input, output_lock

    inputs: list[str] = []
    outputs: list[tuple[str, bool]] = []
    for action in parser._actions:
        role = getattr(action.type, "role", None)
        if role not in ROLES:
            continue
        for value in _values(getattr(args, action.dest, None)):
            if role == "input":
                if os.path.lexists(value):  # a stand's K in `stack --kappa K FILE` is no path
                    inputs.append(value)
                    pulls_in = getattr(action.type, "pulls_in", None)
                    if pulls_in is not None:  # a mesh's material libraries and maps, a glTF's buffers
                        inputs.extend(pulls_in(value))
            elif value.strip():
                outputs.append((value, role == "output_folder"))
    check_not_input(outputs, inputs)
    with ExitStack() as stack:
        for out, folder in outputs:
            p = Path(out)
            if p.name in ("", ".", "..") or out.endswith(("/", os.sep)) or (not folder and p.is_dir()):
                continue  # not a file name: the command refuses it with its own message
            if p.absolute().parent.is_dir():  # a folder yet to be made locks itself (output_folder)
                stack.enter_context(output_lock(p))
        yield


def name_or_index(*, hi: int = 63, pattern: str = r"[A-Za-z_][A-Za-z0-9_]{0,31}") -> _Type:
    """A non-negative index in ``[0, hi]`` (returned as :class:`int`) or a name matching ``pattern``."""

    def parse(text: str) -> int | str:
        t = str(text).strip()
        if re.fullmatch(r"[+-]?\d+", t):
            return _parse_int(t, 0, hi)
        if re.fullmatch(pattern, t):
            return t
        raise argparse.ArgumentTypeError(
            f"expected an index in [0, {hi}] or a name like G, got {text!r}")

    return _named(parse, "channel")


def keyword(words: Iterable[str], otherwise: _Type | None = None) -> _Type:
    """One of ``words`` (returned as given), else the value parsed by ``otherwise``.

    ``keyword(("auto", "white"), finite_float(0, lo_open=True))`` is the
    mosaic's ``--exposure``.
    """
    allowed = tuple(words)

    def parse(text: str) -> Any:
        if text in allowed:
            return text
        if otherwise is not None:
            try:
                return otherwise(text)
            except argparse.ArgumentTypeError as exc:
                raise argparse.ArgumentTypeError(
                    f"{exc} (or one of {', '.join(allowed)})") from None
        raise argparse.ArgumentTypeError(f"expected one of {', '.join(allowed)}, got {text!r}")

    return _named(parse, "value")


def key_value(*, pattern: str = r"[A-Za-z_][A-Za-z0-9_]*") -> _Type:
    """``KEY=VALUE`` (Mitsuba's ``-D``): returns ``(key, value)``; the key matches ``pattern``."""

    def parse(text: str) -> tuple[str, str]:
        key, sep, value = str(text).partition("=")
        key = key.strip()
        if not sep or not re.fullmatch(pattern, key):
            raise argparse.ArgumentTypeError(f"expected NAME=VALUE with a name like spp, got {text!r}")
        return key, value

    return _named(parse, "NAME=VALUE")
