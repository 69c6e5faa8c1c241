"""Exceptions raised by :mod:`cdbrdf`.

Every error about user input derives from :class:`CDBRDFError` and, so that
``except ValueError`` keeps working, from :class:`ValueError` (or
:class:`OSError` for a missing system library). Each message is one line that
names the argument, file or limit at fault and the problem.
"""

from __future__ import annotations

__all__ = [
    "CDBRDFError",
    "TableError",
    "FormatError",
    "QueryError",
    "ImageError",
    "MeshError",
    "SceneError",
    "CaptureError",
    "LimitError",
    "OptionError",
    "OutputError",
]


class CDBRDFError(Exception):
    """Base class of every error raised on purpose by :mod:`cdbrdf`."""


class TableError(CDBRDFError, ValueError):
    """A :class:`cdbrdf.CDBRDF` was given inconsistent axes, values or mask."""


class FormatError(CDBRDFError, ValueError):
    """A file is not a valid CDBRDF file; the message names the file."""


class QueryError(CDBRDFError, ValueError):
    """A lookup was given an impossible direction (the message names it)."""


class ImageError(CDBRDFError, ValueError):
    """A photograph cannot be read (corrupt, truncated or unsupported); names the file."""


class MeshError(CDBRDFError, ValueError):
    """A mesh cannot be used (degenerate, inconsistent, bad arrays); names the mesh."""


class SceneError(CDBRDFError, ValueError):
    """A Mitsuba scene cannot be rendered with the plug-in as given; names the shape or file."""


class CaptureError(CDBRDFError, ValueError):
    """The capture folder or table is malformed; the message names the file and line."""


class LimitError(CDBRDFError, ValueError):
    """An input asks for more than a configured limit (:mod:`cdbrdf.limits`).

    The message names the limit, the amount asked for and the environment
    variable that raises it.
    """


class OptionError(CDBRDFError, ValueError):
    """An option or argument of a library function has an invalid value.

    The message names the option, the value given and the valid values
    (e.g. ``scheduler``, ``compression``, a material name, an image array of
    the wrong shape or type).
    """


class OutputError(CDBRDFError, ValueError):
    """An output cannot be written without destroying something or colliding with another run.

    It is one of the run's inputs (or a folder holding one), an output
    folder that another command made, or another run is writing it. The
    message names the output and the reason; nothing has been written.
    """
