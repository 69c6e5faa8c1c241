"""The ``cdbrdf`` command line: a thin layer over the library.

Each sub-command lives in :mod:`cdbrdf.commands` as a module ``NAME`` with
``register(subparsers)`` (adds its parser and ``set_defaults(func=run)``) and
``run(args) -> int``. User errors (:class:`ValueError`, :class:`OSError`,
:class:`cdbrdf.CDBRDFError`) print one line to stderr and exit with status 2;
``--debug`` shows the traceback instead.
"""

from __future__ import annotations

import argparse
import importlib
import logging
import re
import sys
from collections.abc import Sequence

__all__ = ["main", "build_parser", "COMMANDS"]

#: Sub-command modules under :mod:`cdbrdf.commands`, in ``--help`` order.
COMMANDS: tuple[str, ...] = (
    "demo",
    "info",
    "mosaic",
    "plan",
    "measure",
    "simulate-capture",
    "curvature",
    "render",
    "synth",
)

EXIT_USER_ERROR = 2
EXIT_INTERRUPTED = 130


def build_parser() -> argparse.ArgumentParser:
    """The argument parser with every sub-command registered."""
    from . import __version__

    parser = argparse.ArgumentParser(
        prog="cdbrdf",
        description="Measure and render curvature-dependent BRDFs (CDBRDF) of fabrics.",
    )
    parser.add_argument("--version", action="version", version=f"cdbrdf {__version__}")
    parser.add_argument("--debug", action="store_true", help="show tracebacks and debug logging")
    parser.add_argument("-q", "--quiet", action="store_true", help="no progress bars or summaries")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name in COMMANDS:
        module = importlib.import_module(f"cdbrdf.commands.{name.replace('-', '_')}")
        module.register(sub)
    return parser


_NEGATIVE_LIST = re.compile(r"^-\d*\.?\d+(e-?\d+)?(,-?\d*\.?\d+(e-?\d+)?)+$")


def _join_negative_lists(argv: Sequence[str]) -> list[str]:
    """``--kappa -0.22,0.13`` -> ``--kappa=-0.22,0.13``.

    argparse takes a value that starts with "-" and is not a plain number for
    an option, so comma-separated lists that start with a negative number
    would be refused; joining them to their option with "=" keeps them values.
    """
    out: list[str] = []
    for a in argv:
        if out and out[-1].startswith("--") and "=" not in out[-1] and _NEGATIVE_LIST.match(a):
            out[-1] = f"{out[-1]}={a}"
        else:
            out.append(a)
    return out


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; returns the exit status."""
    argv = _join_negative_lists(sys.argv[1:] if argv is None else argv)
    if argv == ["--version"]:  # answered without importing the sub-commands (and numba)
        from . import __version__

        print(f"cdbrdf {__version__}")
        sys.exit(0)  # as argparse's version action
    parser = build_parser()
    args = parser.parse_args(argv)
    logging.basicConfig(
        level=logging.DEBUG if args.debug else logging.WARNING,
        format="%(levelname)s %(name)s: %(message)s",
    )
    if not getattr(args, "func", None):
        parser.print_help(sys.stderr)
        return EXIT_USER_ERROR
    try:
        return int(args.func(args) or 0)
    except KeyboardInterrupt:
        print("cdbrdf: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    except (ValueError, OSError, LookupError) as exc:
        if args.debug:
            raise
        from .errors import CDBRDFError

        kind = "" if isinstance(exc, CDBRDFError) else f"{type(exc).__name__}: "
        print(f"cdbrdf {args.command}: error: {kind}{exc}", file=sys.stderr)
        return EXIT_USER_ERROR


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
