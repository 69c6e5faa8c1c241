"""Shared fixtures: small tables with known contents."""

from __future__ import annotations

import numpy as np
import pytest

import cdbrdf


def make_table(grid: cdbrdf.Grid, *, seed: int = 0, channels: int = 3, dtype=np.float64, **kw):
    """A table of random values in [0.1, 1.1) on ``grid``."""
    rng = np.random.default_rng(seed)
    values = (0.1 + rng.random(grid.shape + (channels,))).astype(dtype)
    return cdbrdf.CDBRDF(values, **grid.axes(), symmetry=grid.symmetry, **kw)


@pytest.fixture
def paper_table() -> cdbrdf.CDBRDF:
    return make_table(cdbrdf.Grid.paper(), attrs={"material": "random", "provenance": {"seed": 0}})


@pytest.fixture
def small_grid() -> cdbrdf.Grid:
    return cdbrdf.Grid(
        kappa=[-0.2, 0.0, 0.05, 0.3],
        theta_l=[0.0, 20.0, 50.0],
        phi_l=[0.0, 90.0, 180.0, 270.0],
        theta_v=[0.0, 30.0, 60.0],
        phi_v=[0.0, 120.0, 240.0],
    )


@pytest.fixture(scope="module")
def browser():
    """Headless Chromium (playwright), one per test module (the viewer's tests; they skip without Chromium)."""
    from playwright.sync_api import sync_playwright

    from .test_viewer import CHROMIUM, CHROMIUM_ARGS

    with sync_playwright() as p:
        b = p.chromium.launch(executable_path=CHROMIUM, headless=True, args=CHROMIUM_ARGS)
        try:
            yield b
        finally:
            b.close()
