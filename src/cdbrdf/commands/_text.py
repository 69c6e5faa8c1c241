"""What the command line prints: every line goes through :func:`say`, which escapes control characters.

Tables, imported files, meshes and capture folders carry text of their own
(material names, descriptions, provenance, comments, file names) that ends
up in what a command prints. A terminal acts on control characters (an
escape sequence can recolour the screen, move the cursor, retitle the
window, hide the rest of a line); :func:`printable` writes each of them,
and every other character that is not printable (bidirectional overrides,
for one), as its Python escape (``\\x1b``, ``\\u202e``), so a file's text is
shown, never executed by the terminal.
"""

from __future__ import annotations

import sys
from typing import TextIO

__all__ = ["printable", "say"]


def printable(text: object, *, newlines: bool = False) -> str:
    """``str(text)`` with every character that is not printable escaped (spaces kept; newlines with ``newlines``)."""
    s = str(text)
    if s.isprintable():
        return s
    return "".join(
        c if c.isprintable() or c == " " or (newlines and c == "\n") else c.encode("unicode_escape").decode("ascii")
        for c in s
    )


def say(*parts: object, err: bool = False, flush: bool = False, file: TextIO | None = None) -> None:
    """Print ``parts`` (joined by spaces) as :func:`print` does, through :func:`printable` (newlines kept).

    ``err`` prints to standard error; ``file`` to another stream.
    """
    stream = file if file is not None else (sys.stderr if err else sys.stdout)
    print(printable(" ".join(str(p) for p in parts), newlines=True), file=stream, flush=flush)
