"""Exceptions raised by :mod:`cdbrdf`.

Every error about user input is a :class:`ValueError` subclass so that
``except ValueError`` keeps working, and names the argument or file at fault.
"""

from __future__ import annotations

__all__ = ["CDBRDFError", "TableError", "FormatError", "QueryError"]


class CDBRDFError(Exception):
    """Base class of every error raised on purpose by :mod:`cdbrdf`."""


class TableError(CDBRDFError, ValueError):
    """A :class:`cdbrdf.CDBRDF` was given inconsistent axes, values or mask."""


class FormatError(CDBRDFError, ValueError):
    """A file is not a valid CDBRDF file; the message names the file."""


class QueryError(CDBRDFError, ValueError):
    """A lookup was given an impossible direction (the message names it)."""
