"""Filling invalid samples from the nearest measured direction at the same curvature."""

from __future__ import annotations

import numpy as np
import pytest

from cdbrdf import CDBRDF, Grid, TableError
from cdbrdf.frames import direction_from_angles
from cdbrdf.measure.fill import fill_nearest


def angular_distance_deg(t1, p1, t2, p2):
    """Independent reference: the half-chord formula 2 asin(|a - b| / 2)."""
    a, b = direction_from_angles(t1, p1), direction_from_angles(t2, p2)
    return np.degrees(2 * np.arcsin(np.clip(np.linalg.norm(a - b, axis=-1) / 2, 0, 1)))


@pytest.fixture
def grid():
    return Grid(kappa=[-0.2, 0.0], theta_l=[0, 30, 60], phi_l=[0, 90, 180, 270],
                theta_v=[0, 30, 60], phi_v=[0, 120, 240])


def test_nothing_to_fill(grid):
    v = np.random.default_rng(0).random(grid.shape + (3,))
    out, src, _ = fill_nearest(v, np.ones(grid.shape, bool), grid)
    np.testing.assert_array_equal(out, v)
    assert (src == -1).all()


def test_fill_is_nearest_by_view_plus_light_angle(grid):
    rng = np.random.default_rng(1)
    v = rng.random(grid.shape + (3,))
    valid = rng.random(grid.shape) > 0.4
    out, src, _ = fill_nearest(np.where(valid[..., None], v, np.nan), valid, grid)
    m = grid.mesh()
    flat = {n: a.ravel() for n, a in m.items()}
    for i in np.flatnonzero(~valid.ravel()):
        j = src.ravel()[i]
        assert valid.ravel()[j]
        # same curvature
        assert flat["kappa"][j] == flat["kappa"][i]
        # brute force: no measured sample at this kappa is strictly nearer
        same = (flat["kappa"] == flat["kappa"][i]) & valid.ravel()
        d = angular_distance_deg(flat["theta_v"][i], flat["phi_v"][i], flat["theta_v"], flat["phi_v"]) + \
            angular_distance_deg(flat["theta_l"][i], flat["phi_l"][i], flat["theta_l"], flat["phi_l"])
        assert d[j] <= d[same].min() + 1e-9
        # tie-break: the lowest flat index among the nearest
        assert j == np.flatnonzero(same & (d <= d[same].min() + 1e-9))[0]
        np.testing.assert_array_equal(out.reshape(-1, 3)[i], v.reshape(-1, 3)[j])
    # the result is a valid table
    t = CDBRDF(out, **grid.axes(), measured=valid, fill_source=src)
    assert t.measured.sum() == valid.sum()


def test_pole_fills_from_same_direction(grid):
    """At theta_v = 0 every phi is one direction: a missing phi copies phi = 0 exactly (distance 0)."""
    v = np.random.default_rng(2).random(grid.shape + (1,))
    valid = np.ones(grid.shape, bool)
    valid[:, :, :, 1:, 0] = False  # theta_v = 0 only photographed at phi_v = 0
    out, src, _ = fill_nearest(v, valid, grid)
    # (at theta_l = 0 the light's azimuths are one direction too: the lowest phi_l wins the tie)
    np.testing.assert_array_equal(out[:, :, 1:, 1, 0], v[:, :, 1:, 0, 0])
    np.testing.assert_array_equal(out[:, :, 1:, 2, 0], v[:, :, 1:, 0, 0])
    np.testing.assert_array_equal(out[:, :, 0, 1, 0], v[:, :1, 0, 0, 0].repeat(4, axis=1))


def test_tie_break_lowest_index():
    g = Grid(kappa=[0.0], theta_l=[45.0], phi_l=[0, 90, 180, 270], theta_v=[0.0], phi_v=[0.0])
    v = np.arange(4, dtype=float).reshape(g.shape + (1,))
    valid = np.array([True, False, True, True]).reshape(g.shape)
    # phi_l = 90 is equally far from 0 and 180: the lower index (phi_l = 0) wins
    out, src, _ = fill_nearest(v, valid, g)
    assert src.ravel()[1] == 0 and out.ravel()[1] == 0.0


def test_std_filled_too(grid):
    v = np.ones(grid.shape + (3,))
    s = np.random.default_rng(3).random(grid.shape + (3,))
    valid = np.ones(grid.shape, bool)
    valid[0, 0, 0, 0, 0] = False
    _, src, s2 = fill_nearest(v, valid, grid, std=s)
    np.testing.assert_array_equal(s2.reshape(-1, 3)[0], s.reshape(-1, 3)[src.ravel()[0]])


def test_curvature_without_measurement_raises(grid):
    valid = np.ones(grid.shape, bool)
    valid[1] = False
    with pytest.raises(TableError, match="kappa = 0 1/mm: no sample was measured"):
        fill_nearest(np.ones(grid.shape + (3,)), valid, grid)
