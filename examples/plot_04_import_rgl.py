"""
Import a measured RGL file
==========================

:func:`cdbrdf.importers.import_brdf` reads a plain BRDF file (an RGL
``.bsdf`` from the EPFL RGL material database, MERL ``.binary`` or UTIA
``.bin``) and returns a one-curvature :class:`cdbrdf.CDBRDF`: every sample
the mean of the source over its cell, an isotropic layout for an isotropic
source, the expected error of the table against the source in its
provenance.

The example reads ``rgl/cc_ibiza_sunset_rgb.bsdf`` from the folder named by
the environment variable ``CDBRDF_SHARED_DATA`` (``scripts/docs.sh`` sets it
when it finds the project's test data). Without it, the example writes a
small synthetic RGL file first, with
:func:`cdbrdf.importers.rgl.write_tensor_file`, so it always runs.
"""

import os
import tempfile
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

from cdbrdf.importers import import_brdf, rgl
from cdbrdf.plot import plot_slice


def synthetic_rgl(path: Path) -> Path:
    """A small valid RGB material: isotropic, 3 incident elevations, 4 x 4 reflectance grid."""
    theta_h = np.linspace(0.0, 1.0, 4)
    rgb = np.empty((1, 3, 3, 4, 4), np.float32)
    for c, base in enumerate((0.30, 0.20, 0.10)):  # reddish, brighter towards the specular peak
        rgb[0, :, c] = base + 0.4 * np.exp(-8.0 * theta_h)[None, :, None]
    rgl.write_tensor_file(path, {
        "version": np.array([1, 0], np.uint32),
        "description": "synthetic red material",
        "phi_i": np.zeros(1, np.float32),
        "theta_i": np.radians([0.0, 45.0, 89.9]).astype(np.float32),
        "sigma": np.ones((2, 8), np.float32),
        "ndf": np.ones((2, 8), np.float32),
        "vndf": np.ones((1, 3, 8, 8), np.float32),
        "luminance": np.ones((1, 3, 4, 4), np.float32),
        "rgb": rgb,
        "jacobian": np.array([1], np.uint8),
        "valid": np.packbits(np.ones(3 * 16, np.uint8)),
    })
    return path


shared = Path(os.environ.get("CDBRDF_SHARED_DATA", "shared-data-not-set"))
source = shared / "rgl" / "cc_ibiza_sunset_rgb.bsdf"
if not source.is_file():
    source = synthetic_rgl(Path(tempfile.mkdtemp()) / "synthetic.bsdf")
print("importing", source.name)

# %%
# A regular target grid of 5 degrees in elevation and 10 degrees in azimuth
# keeps the import to a few seconds (``grid="default"`` is finer).
table = import_brdf(source, grid="regular:5,10", kappa=0.0)
print(table)
print("expected error:", table.attrs["provenance"].get("expected_error"))

# %%
# The imported table is a CDBRDF like any other: saved, looked up, plotted.
fig, ax = plt.subplots(figsize=(6, 3.6), layout="constrained")
plot_slice(table, theta_l_deg=30.0, phi_l_deg=0.0, ax=ax)
plt.show()
