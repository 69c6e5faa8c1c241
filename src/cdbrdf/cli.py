"""The ``cdbrdf`` command line: a thin layer over the library.

Each sub-command lives in :mod:`cdbrdf.commands` as a module ``NAME`` with
``register(subparsers)`` (adds its parser and ``set_defaults(func=run)``) and
``run(args) -> int``. Options are validated while they are parsed by the
types of :mod:`cdbrdf.commands._args`. Bad arguments and user errors
(:class:`ValueError`, :class:`OSError`, :class:`cdbrdf.CDBRDFError`) print one
line ``cdbrdf COMMAND: error: MESSAGE`` to stderr and exit with status 2; so do
:class:`MemoryError` and :class:`RecursionError` (naming the limits that bound
the work). The limit variables (:mod:`cdbrdf.limits`) are checked before the
options are parsed (one line naming a bad one, status 2). ``--debug`` shows the traceback instead.

Every command runs under the one output rule (:func:`cdbrdf.commands._args.guarded`:
no output is, holds or lies inside an input; one run at a time per output).
Everything printed, log lines included, goes through
:func:`cdbrdf.commands._text.printable` (a file's escape sequences never reach
the terminal). When the reader of the output goes away (``cdbrdf info f.h5 |
head -1``) the command ends quietly with status 141, as a Unix tool killed by
SIGPIPE does.
"""

from __future__ import annotations

import argparse
import importlib
import keyword
import logging
import re
import sys
from collections.abc import Sequence
from typing import NoReturn

__all__ = ["main", "build_parser", "COMMANDS", "Parser"]

#: Sub-command modules under :mod:`cdbrdf.commands`, in ``--help`` order.
COMMANDS: tuple[str, ...] = (
    "demo",
    "info",
    "mosaic",
    "import",
    "stack",
    "bend",
    "plan",
    "measure",
    "simulate-capture",
    "curvature",
    "render",
    "export",
    "synth",
    "view",
)

EXIT_USER_ERROR = 2
EXIT_INTERRUPTED = 130
#: 128 + SIGPIPE: what a shell reports for a tool whose reader went away.
EXIT_BROKEN_PIPE = 141


class Parser(argparse.ArgumentParser):
    """An :class:`argparse.ArgumentParser` whose errors are one line, not usage + message.

    :meth:`error` prints ``cdbrdf COMMAND: error: MESSAGE`` to stderr and exits
    with status 2. Sub-parsers are of the same class (argparse creates them
    with the parent's class).
    """

    def error(self, message: str) -> NoReturn:  # noqa: D102 - argparse API
        self.exit(EXIT_USER_ERROR, f"{self.prog}: error: {_one_line(message)}\n")


def _one_line(text: str) -> str:
    """One line of text, its control characters escaped (:func:`cdbrdf.commands._text.printable`)."""
    from .commands._text import printable

    return printable(" ".join(str(text).split()))


class _PrintableFormatter(logging.Formatter):
    """Log lines with the control characters of their (file-provided) text escaped."""

    def format(self, record: logging.LogRecord) -> str:  # noqa: D102 - logging API
        from .commands._text import printable

        return printable(super().format(record), newlines=True)


def _quiet_stdout() -> None:
    """Send what is left for standard output to the null device (its reader went away)."""
    import os

    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        os.close(devnull)
    except (OSError, ValueError, AttributeError):  # pragma: no cover - stdout without a descriptor
        pass


def _module(command: str) -> str:
    """The module of a sub-command: dashes become underscores, a Python keyword gets one appended (import_)."""
    name = command.replace("-", "_")
    return f"{name}_" if keyword.iskeyword(name) else name


def _subparser(parser: argparse.ArgumentParser, command: str) -> argparse.ArgumentParser:
    """The parser of one sub-command."""
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            return action.choices[command]
    raise LookupError(f"no sub-command {command!r}")  # pragma: no cover - build_parser registers them all


def build_parser() -> argparse.ArgumentParser:
    """The argument parser with every sub-command registered."""
    from ._version import __version__

    parser = Parser(
        prog="cdbrdf",
        description="Measure and render curvature-dependent BRDFs (CDBRDF) of fabrics.",
    )
    parser.add_argument("--version", action="version", version=f"cdbrdf {__version__}")
    parser.add_argument("--debug", action="store_true", help="show tracebacks and debug logging")
    parser.add_argument("-q", "--quiet", action="store_true", help="no progress bars or summaries")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name in COMMANDS:
        module = importlib.import_module(f"cdbrdf.commands.{_module(name)}")
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


#: The limits (:data:`cdbrdf.limits.LIMITS`' names) that bound the memory of each command, named when it runs out.
_MEMORY_HINTS: dict[str, tuple[str, ...]] = {
    "render": ("render_pixels", "mesh_faces"),
    "curvature": ("mesh_faces",),
    "plan": ("capture_rows",),
    "simulate-capture": ("capture_rows", "render_pixels"),
    "synth": ("table_samples",),
    "bend": ("table_samples",),
    "measure": ("image_pixels", "table_samples"),
}


def _memory_hint(command: str) -> str:
    """The environment variables of the limits that bound ``command``'s memory (owned by :mod:`cdbrdf.limits`)."""
    from .limits import LIMITS

    return ", ".join(LIMITS[name].env for name in _MEMORY_HINTS.get(command, ()))


def _version_only(argv: Sequence[str]) -> bool:
    """``--version`` before any command: answered without importing the commands."""
    for a in argv:
        if a == "--version":
            return True
        if not a.startswith("-"):
            return False
    return False


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; returns the exit status.

    Parameters
    ----------
    argv
        Arguments without the program name (default ``sys.argv[1:]``).

    Returns
    -------
    int
        0 on success, 2 for a user error, 130 when interrupted, 141 when the
        reader of standard output went away. Bad arguments,
        ``--help`` and ``--version`` exit through :class:`SystemExit` (status
        2, 0 and 0).
    """
    argv = list(sys.argv[1:] if argv is None else argv)
    if _version_only(argv):
        from ._version import __version__

        print(f"cdbrdf {__version__}")
        raise SystemExit(0)
    if not {"-h", "--help"} & set(argv):
        # a bad CDBRDF_MAX_* variable: one line naming it, before the options that use it are parsed
        from .errors import LimitError
        from .limits import check_environment

        try:
            check_environment()
        except LimitError as exc:
            if "--debug" in argv:
                raise
            command = next((a for a in argv if not a.startswith("-")), "")
            where = f"cdbrdf {command}" if command in COMMANDS else "cdbrdf"
            print(f"{where}: error: {_one_line(str(exc))}", file=sys.stderr)
            return EXIT_USER_ERROR
    parser = build_parser()
    args = parser.parse_args(_join_negative_lists(argv))
    handler = logging.StreamHandler()
    handler.setFormatter(_PrintableFormatter("%(levelname)s %(name)s: %(message)s"))
    logging.basicConfig(level=logging.DEBUG if args.debug else logging.WARNING, handlers=[handler])
    if not getattr(args, "func", None):
        parser.print_help(sys.stderr)
        return EXIT_USER_ERROR
    try:
        from .commands._args import guarded

        with guarded(_subparser(parser, args.command), args):
            status = int(args.func(args) or 0)
        sys.stdout.flush()  # a reader gone away is seen here, not at exit
        return status
    except KeyboardInterrupt:
        print("cdbrdf: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    except BrokenPipeError:
        _quiet_stdout()
        return EXIT_BROKEN_PIPE
    except (ValueError, OSError, LookupError) as exc:
        if args.debug:
            raise
        from .errors import CDBRDFError

        kind = "" if isinstance(exc, CDBRDFError) else f"{type(exc).__name__}: "
        print(f"cdbrdf {args.command}: error: {kind}{_one_line(str(exc))}", file=sys.stderr)
        return EXIT_USER_ERROR
    except (MemoryError, RecursionError) as exc:
        if args.debug:
            raise
        what = "out of memory" if isinstance(exc, MemoryError) else "input nested too deeply"
        hint = _memory_hint(args.command)
        hint = f"; lower the sizes asked for{' or the limits ' + hint if hint else ''}"
        print(f"cdbrdf {args.command}: error: {what} while running {args.command}{hint}",
              file=sys.stderr)
        return EXIT_USER_ERROR


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
