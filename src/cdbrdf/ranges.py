"""The accepted range of a numeric option: one owner, read by the record that checks it and by the command line.

A :class:`Range` is declared once, beside the record whose field it bounds
(e.g. :data:`cdbrdf.render.spec.SPP_RANGE`); the record checks its values
with :meth:`Range.check` and the command line parses the option with the
same range (``cdbrdf.commands._args.in_range``) and says it in the help
(:meth:`Range.text`), so that the library and the command line never
disagree on what is accepted.

>>> from cdbrdf.ranges import Range
>>> spp = Range(1, 65536, integer=True)
>>> spp.check("spp", 64)
64
>>> spp.text()
'1 to 65536'
>>> Range(0, 1.5, lo_open=True).expect()
'a number in (0, 1.5]'
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass
from typing import Any

from .errors import OptionError

__all__ = ["Range"]


def _fmt(x: float, integer: bool = False) -> str:
    return str(int(x)) if integer else f"{x:g}"


@dataclass(frozen=True)
class Range:
    """A closed, open or half-open interval of numbers, or of whole numbers.

    Attributes
    ----------
    lo, hi
        The bounds; None for none (a number must still be finite).
    lo_open, hi_open
        Whether the bound itself is excluded (``lo=0, lo_open=True``: positive).
    unit
        The unit, named in messages and help (``"mm"``, ``"EV"``).
    integer
        Whole numbers only.
    """

    lo: float | None = None
    hi: float | None = None
    lo_open: bool = False
    hi_open: bool = False
    unit: str = ""
    integer: bool = False

    def __contains__(self, x: object) -> bool:
        if isinstance(x, bool) or not isinstance(x, numbers.Real):
            return False
        if self.integer and not isinstance(x, numbers.Integral):
            return False
        v = float(x)
        if not math.isfinite(v):
            return False
        if self.lo is not None and not (v > self.lo if self.lo_open else v >= self.lo):
            return False
        return self.hi is None or (v < self.hi if self.hi_open else v <= self.hi)

    def expect(self) -> str:
        """What is expected, for a message.

        Returns
        -------
        str
            ``"an integer in [1, 64]"``, ``"a number in (0, 1.5] mm"``, ...
        """
        if self.integer:
            bounded = self.lo is not None and self.hi is not None
            text = f"an integer in [{_fmt(self.lo, True)}, {_fmt(self.hi, True)}]" if bounded else "an integer"  # type: ignore[arg-type]
        elif self.lo is None and self.hi is None:
            text = "a finite number"
        elif self.hi is None and self.lo == 0 and self.lo_open:
            text = "a positive number"
        elif self.hi is None:
            text = f"a number {'>' if self.lo_open else '>='} {_fmt(self.lo)}"  # type: ignore[arg-type]
        elif self.lo is None:
            text = f"a number {'<' if self.hi_open else '<='} {_fmt(self.hi)}"
        else:
            text = (f"a number in {'(' if self.lo_open else '['}{_fmt(self.lo)}, {_fmt(self.hi)}"
                    f"{')' if self.hi_open else ']'}")
        return text + (f" {self.unit}" if self.unit and not self.integer else "")

    def text(self) -> str:
        """The range for help text.

        Returns
        -------
        str
            ``"1 to 65536"``, ``"in (0, 1.5]"``, ``"> 0 mm"``, ...
        """
        unit = f" {self.unit}" if self.unit else ""
        if self.lo is not None and self.hi is not None and not (self.lo_open or self.hi_open):
            return f"{_fmt(self.lo, self.integer)} to {_fmt(self.hi, self.integer)}{unit}"
        if self.lo is not None and self.hi is not None:
            return (f"in {'(' if self.lo_open else '['}{_fmt(self.lo)}, {_fmt(self.hi)}"
                    f"{')' if self.hi_open else ']'}{unit}")
        if self.lo is not None:
            return f"{'>' if self.lo_open else '>='} {_fmt(self.lo)}{unit}"
        if self.hi is not None:
            return f"{'<' if self.hi_open else '<='} {_fmt(self.hi)}{unit}"
        return "finite"

    def check(self, name: str, value: Any) -> Any:
        """``value`` as a float (an int for :attr:`integer`) when it lies in the range.

        Parameters
        ----------
        name
            The option's name, for the message.
        value
            The value given.

        Returns
        -------
        float or int
            The value.

        Raises
        ------
        OptionError
            ``"NAME: expected <range>, got VALUE"`` (one line).
        """
        if value not in self:
            raise OptionError(f"{name}: expected {self.expect()}, got {value!r:.40}")
        return int(value) if self.integer else float(value)
