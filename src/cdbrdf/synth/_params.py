"""What the fabric models' parameter sets share: names, validated copies, JSON and command-line values.

:class:`ModelParams` is the base of the frozen dataclasses
:class:`~cdbrdf.synth.cloth.ClothParams` and
:class:`~cdbrdf.synth.pile.PileParams`; each names its kind (``_KIND``, for
the messages) and may read some parameters' text its own way
(``_parse_special``).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import fields
from typing import Any, TypeVar

import numpy as np

from ..errors import OptionError

__all__: list[str] = []

_P = TypeVar("_P", bound="ModelParams")

#: No special reading: :meth:`ModelParams._parse_special`'s answer for an ordinary parameter.
NOT_SPECIAL = object()


def is_real(v: Any) -> bool:
    """A finite real number (not a bool)."""
    return isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, bool) and math.isfinite(v)


class ModelParams:
    """Methods every parameter dataclass of a fabric model has (a base without fields)."""

    #: The kind of fabric, as the messages name it ("cloth", "pile").
    _KIND = "model"

    @classmethod
    def names(cls) -> list[str]:
        """Valid parameter names."""
        return [f.name for f in fields(cls)]  # type: ignore[arg-type]

    def replace(self: _P, **changes: Any) -> _P:
        """A copy with some parameters changed (validated).

        Parameters
        ----------
        **changes
            New values by parameter name.

        Returns
        -------
        ModelParams
            The copy, of the same class.

        Raises
        ------
        OptionError
            For an unknown parameter name (the message lists the valid ones)
            or an invalid value.
        """
        unknown = sorted(set(changes) - set(self.names()))
        if unknown:
            raise OptionError(f"unknown {self._KIND} parameter(s) {', '.join(map(repr, unknown))}; "
                              f"valid names: {', '.join(self.names())}")
        return dataclasses.replace(self, **changes)  # type: ignore[type-var]

    def to_dict(self) -> dict[str, Any]:
        """JSON-friendly parameters (tuples, nested ones too, become lists).

        Returns
        -------
        dict
            Every parameter by name.
        """
        out: dict[str, Any] = {}
        for f in fields(self):  # type: ignore[arg-type]
            v = getattr(self, f.name)
            if isinstance(v, tuple):
                v = [list(x) if isinstance(x, tuple) else x for x in v]
            out[f.name] = v
        return out

    @classmethod
    def _parse_special(cls, name: str, text: str) -> Any:
        """A parameter read its own way (:data:`NOT_SPECIAL` for the ordinary ones; ValueError if unreadable)."""
        return NOT_SPECIAL

    @classmethod
    def parse_value(cls, name: str, text: str) -> Any:
        """Convert a command-line value for a parameter.

        Parameters
        ----------
        name
            The parameter.
        text
            Its value as typed (colours as ``r,g,b``).

        Returns
        -------
        Any
            The value, of the parameter's type.

        Raises
        ------
        OptionError
            For an unknown name (listing the valid ones) or unreadable text.
        """
        if name not in cls.names():
            raise OptionError(f"unknown {cls._KIND} parameter {name!r}; valid names: {', '.join(cls.names())}")
        default = next(f.default for f in fields(cls) if f.name == name)  # type: ignore[arg-type]
        t = text.strip()
        try:
            special = cls._parse_special(name, t)
            if special is not NOT_SPECIAL:
                return special
            if isinstance(default, tuple):
                return tuple(float(x) for x in t.split(","))
            if isinstance(default, bool):
                raise ValueError
            if isinstance(default, int):
                return int(t)
            if isinstance(default, float):
                return float(t)
            return t
        except ValueError:
            raise OptionError(f"{name}: cannot read {text!r} as a value of this parameter") from None
