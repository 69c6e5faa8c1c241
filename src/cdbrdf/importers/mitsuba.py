"""Any Mitsuba 3 BSDF as a source: tabulate an analytic material (e.g. to test the import on a known answer).

``source({"type": "roughconductor", "alpha": 0.05})`` evaluates the BSDF with
Mitsuba in ``llvm_ad_rgb`` (``eval`` divided by the cosine of the light
direction, ``si.wi`` the view), so a table imported from it can be rendered
beside the BSDF itself (:mod:`cdbrdf.importers.reference`). Mitsuba's BSDFs
are evaluated in their local frame; isotropic ones (the default unless
``isotropic=False``) are imported onto the isotropic layout.
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .source import Source, file_sha256, mitsuba, mitsuba_brdf

__all__ = ["source"]



def source(bsdf: Mapping[str, Any], *, isotropic: bool = True, material: str | None = None,
           quantity: str = "brdf") -> Source:
    """A :class:`~cdbrdf.importers.source.Source` evaluating the Mitsuba BSDF dict ``bsdf``.

    Raises
    ------
    ValueError
        When Mitsuba refuses the dict.
    """
    from .rgl import rgb_variant

    mi, _ = mitsuba()
    with rgb_variant():
        try:
            obj = mi.load_dict(dict(bsdf))
        except RuntimeError as exc:
            raise ValueError(f"bsdf: Mitsuba refuses {dict(bsdf)!r} ({str(exc).splitlines()[-1][:200]})") from None
    text = json.dumps(dict(bsdf), sort_keys=True, default=str)

    def evaluate(theta_v: NDArray[np.float64], phi_v: NDArray[np.float64], theta_l: NDArray[np.float64],
                 phi_l: NDArray[np.float64]) -> tuple[NDArray[np.float64], None]:
        with rgb_variant():  # the variant the BSDF was loaded in
            f, _, _ = mitsuba_brdf(obj, theta_v, phi_v, theta_l, phi_l)
            return np.array(f, dtype=np.float64).T, None

    return Source(
        path=Path(f"mitsuba:{bsdf.get('type', '?')}"), format="mitsuba",
        symmetry="isotropic" if isotropic else "anisotropic", quantity=quantity,
        colour_space="linear Rec.709 (sRGB primaries)", material=material or str(bsdf.get("type", "mitsuba")),
        description=text, details={"bsdf": text}, evaluate=evaluate, sha256=file_sha256(text.encode()),
    )
