"""The integration-error study of the fabric model (``docs/fabric-model.md``).

:func:`convergence` compares the model at a few point and texel counts with a
fine reference; ``scripts/fabric_figures.py --convergence`` prints the table.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from .metrics import luminance

__all__ = ["convergence"]


def convergence(name: str, *, points: Sequence[int] = (1597, 2584, 4181, 6765),
                texels: Sequence[int] = (128, 192, 256), ref_points: int = 17711,
                ref_texels: int = 384) -> list[tuple[int, int, float, float]]:
    """Integration error against a fine reference on a sub-grid of the paper's grid.

    Parameters
    ----------
    name
        A preset (:func:`cdbrdf.synth.presets.names`).
    points, texels
        The settings compared (every combination).
    ref_points, ref_texels
        The reference's settings.

    Returns
    -------
    list of tuple
        Rows ``(points, texels, rms relative error, max relative error)`` of the
        luminance over view/light elevations 0..75 step 15, azimuths 0..330
        step 60, kappa in {0, 0.22}; the error is relative to
        ``max(reference, 0.1 * mean reference)``.
    """
    from .presets import model as preset_model

    T = np.arange(0.0, 76.0, 15.0)
    P = np.arange(0.0, 360.0, 60.0)
    TL, PL, TV, PV, K = np.meshgrid(T, P, T, P, [0.0, 0.22], indexing="ij")
    ref = luminance(preset_model(name, points=ref_points, texels=ref_texels).evaluate(TV, PV, TL, PL, K))
    rows = []
    scale = ref.mean()
    for tx in texels:
        for r in points:
            y = luminance(preset_model(name, points=r, texels=tx).evaluate(TV, PV, TL, PL, K))
            e = np.abs(y - ref) / np.maximum(ref, 0.1 * scale)
            rows.append((r, tx, float(np.sqrt(np.mean(e**2))), float(e.max())))
    return rows
