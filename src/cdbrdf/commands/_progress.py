"""Progress bars of the command line: the one adapter from library callbacks to tqdm.

The library reports progress through plain callbacks, ``progress(done,
total)`` for one stage or ``progress(stage, done, total)`` for several
(:func:`cdbrdf.measure.measure`, :func:`cdbrdf.rig.simulate_capture`,
:func:`cdbrdf.demo.run_demo`, ...); it never draws anything. The commands
turn those calls into tqdm bars on standard error with :class:`ProgressBars`:
one bar per stage, a stage's bar closed when the next stage starts, nothing
drawn with ``quiet``.
"""

from __future__ import annotations

import sys
from collections.abc import Callable
from types import TracebackType
from typing import Any

__all__ = ["ProgressBars"]


class ProgressBars:
    """tqdm bars fed by progress callbacks, one bar per stage.

    Parameters
    ----------
    quiet
        Draw nothing (the callbacks still work).
    unit
        Unit shown after the counts (``"img"``, ``"spp"``, ...).
    leave
        Keep each finished bar on the screen.
    mininterval
        Seconds between redraws.

    Examples
    --------
    >>> with ProgressBars(quiet=True, unit="img") as bars:
    ...     cb = bars.callback("measure")
    ...     cb(3, 10)
    """

    def __init__(self, *, quiet: bool = False, unit: str = "", leave: bool = False,
                 mininterval: float = 0.5) -> None:
        self._quiet = quiet
        self._kw: dict[str, Any] = dict(unit=unit, leave=leave, mininterval=mininterval,
                                        file=sys.stderr, dynamic_ncols=True)
        self._bars: dict[str, Any] = {}

    def update(self, stage: str, done: int, total: int) -> None:
        """Show ``done`` of ``total`` for ``stage`` (a new stage closes the others' bars)."""
        if self._quiet:
            return
        bar = self._bars.get(stage)
        if bar is None:
            from tqdm import tqdm

            for other in self._bars.values():
                other.close()
            bar = self._bars[stage] = tqdm(total=total, desc=stage, **self._kw)
        if bar.total != total:
            bar.total = total
        bar.update(done - bar.n)  # tqdm redraws at most every mininterval

    def callback(self, stage: str) -> Callable[[int, int], None]:
        """A ``progress(done, total)`` callback drawing the bar of ``stage``."""
        return lambda done, total: self.update(stage, done, total)

    def close(self) -> None:
        """Close every bar."""
        for bar in self._bars.values():
            bar.close()
        self._bars.clear()

    def __enter__(self) -> ProgressBars:
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.close()
