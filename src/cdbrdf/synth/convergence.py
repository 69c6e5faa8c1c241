"""The integration-error study of the fabric model (``docs/fabric-model.md``).

:func:`convergence` compares the model at a few ray and texel counts with a
fine reference; ``scripts/fabric_figures.py --convergence`` prints the table.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from .metrics import luminance

__all__ = ["convergence"]


def convergence(name: str, *, rays: Sequence[int] = (377, 987, 1597, 2584),
                texels: Sequence[int] = (64, 128, 192), ref_rays: int = 6765,
                ref_texels: int = 256) -> list[tuple[int, int, float, float]]:
    """Integration error against a fine reference on a sub-grid of the paper's grid.

    Parameters
    ----------
    name
        A preset (:func:`cdbrdf.synth.presets.names`).
    rays, texels
        The settings compared (every combination).
    ref_rays, ref_texels
        The reference's settings.

    Returns
    -------
    list of tuple
        Rows ``(rays, texels, rms relative error, max relative error)`` of the
        luminance over view/light elevations 0..75 step 15, azimuths 0..330
        step 60, kappa in {0, 0.22}; the error is relative to
        ``max(reference, 0.1 * mean reference)``.
    """
    from .presets import model as preset_model

    T = np.arange(0.0, 76.0, 15.0)
    P = np.arange(0.0, 360.0, 60.0)
    TL, PL, TV, PV, K = np.meshgrid(T, P, T, P, [0.0, 0.22], indexing="ij")
    ref = luminance(preset_model(name, rays=ref_rays, texels=ref_texels).evaluate(TV, PV, TL, PL, K))
    rows = []
    scale = ref.mean()
    for tx in texels:
        for r in rays:
            y = luminance(preset_model(name, rays=r, texels=tx).evaluate(TV, PV, TL, PL, K))
            e = np.abs(y - ref) / np.maximum(ref, 0.1 * scale)
            rows.append((r, tx, float(np.sqrt(np.mean(e**2))), float(e.max())))
    return rows
