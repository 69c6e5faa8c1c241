"""cdbrdf.importers.mitsuba: a Mitsuba BSDF dict as a source, against analytic answers."""

from __future__ import annotations

import numpy as np
import pytest

from cdbrdf.importers import mitsuba as mitsuba_source


def _directions(n: int, seed: int = 0) -> list[np.ndarray]:
    rng = np.random.default_rng(seed)
    return [rng.uniform(0, 80, n), rng.uniform(0, 360, n), rng.uniform(0, 80, n), rng.uniform(0, 360, n)]


def test_diffuse_is_albedo_over_pi() -> None:
    """Mitsuba's diffuse BSDF is reflectance / pi sr^-1 at every pair (eval divided by the cosine)."""
    src = mitsuba_source.source({"type": "diffuse", "reflectance": {"type": "rgb", "value": [0.2, 0.5, 0.8]}})
    values, measured = src.evaluate(*_directions(200))
    assert measured is None
    np.testing.assert_allclose(values, np.broadcast_to([0.2 / np.pi, 0.5 / np.pi, 0.8 / np.pi], values.shape),
                               rtol=1e-5)


def test_rough_conductor_is_reciprocal_and_glossy() -> None:
    """Swapping view and light gives the same BRDF; the mirror direction is brighter than off-specular."""
    src = mitsuba_source.source({"type": "roughconductor", "alpha": 0.2})
    tv, pv, tl, pl = _directions(300, seed=1)
    forward, _ = src.evaluate(tv, pv, tl, pl)
    backward, _ = src.evaluate(tl, pl, tv, pv)
    np.testing.assert_allclose(forward, backward, rtol=2e-4, atol=1e-6)
    mirror, _ = src.evaluate(np.array([30.0]), np.array([0.0]), np.array([30.0]), np.array([180.0]))
    off, _ = src.evaluate(np.array([30.0]), np.array([0.0]), np.array([30.0]), np.array([90.0]))
    assert np.all(mirror > 10 * off)


def test_refused_dict_is_one_line() -> None:
    with pytest.raises(ValueError, match="Mitsuba refuses") as info:
        mitsuba_source.source({"type": "no-such-bsdf"})
    assert "\n" not in str(info.value)
