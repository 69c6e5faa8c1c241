"""Tables with known contents for the tests of :mod:`cdbrdf.plot`."""

from __future__ import annotations

import struct

import numpy as np

import cdbrdf

KAPPA = [-0.1, 0.0, 0.2]
PHI_L = [0.0, 90.0, 180.0, 270.0]
THETA_L = [0.0, 40.0]
PHI_V = [0.0, 120.0, 240.0]
THETA_V = [0.0, 30.0, 60.0]


def code(k, pl, tl, pv, tv, c):
    """The value stored at an index: every index readable from the number."""
    return 10000 * k + 1000 * pl + 100 * tl + 10 * pv + tv + 0.125 * c


def index_table(measured=None, kappa=KAPPA, **kw):
    nk = len(kappa)
    shape = (nk, len(PHI_L), len(THETA_L), len(PHI_V), len(THETA_V), 3)
    v = np.fromfunction(code, shape)
    return cdbrdf.CDBRDF(
        v, kappa=kappa, phi_l=PHI_L, theta_l=THETA_L, phi_v=PHI_V, theta_v=THETA_V,
        measured=measured, **kw,
    )


def const_table(value, kappa=(-0.13, 0.0, 0.13), quantity="brdf", n_channels=3):
    g = cdbrdf.Grid.regular(theta_step_deg=25, phi_step_deg=90, kappa=kappa)
    v = np.broadcast_to(np.asarray(value, float), g.shape + (n_channels,))
    return cdbrdf.CDBRDF(v, g, attrs={"quantity": quantity, "material": "grey card"})


def png_size(data: bytes) -> tuple[int, int]:
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    return struct.unpack(">II", data[16:24])


def image_axes(fig):
    """The axes of a figure that show an image (colour bars left out)."""
    return [ax for ax in fig.axes if ax.images and ax.get_label() != "<colorbar>"]
