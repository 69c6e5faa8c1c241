"""
The file, and the table as an xarray Dataset
============================================

A table is saved as one HDF5 / NetCDF-4 file (``docs/format.md``): written
atomically, with checksums, read back exactly by :func:`cdbrdf.load`.
:meth:`~cdbrdf.CDBRDF.to_xarray` gives an :class:`xarray.Dataset` with named
dimensions (``kappa``, ``phi_l``, ``theta_l``, ``phi_v``, ``theta_v``,
``channel``), so the samples can be selected and plotted by name.
"""

import tempfile
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

import cdbrdf
import cdbrdf.materials

table = cdbrdf.materials.load("denim")
work = tempfile.TemporaryDirectory()  # removed when the example ends
path = Path(work.name) / "denim.h5"
table.save(path)
back = cdbrdf.load(path)
print(path.name, f"{path.stat().st_size / 1e6:.1f} MB;", "same values:", np.array_equal(back.values, table.values))

# %%
# The samples by name: green reflectance for the light at 45 degrees
# elevation, azimuth 0, over the view elevation in the plane of incidence
# (view azimuth 180), one curve per curvature.
ds = back.to_xarray()
print(ds["reflectance"].dims)
curve = ds["reflectance"].sel(theta_l=45.0, phi_l=0.0, phi_v=180.0, channel="G")

fig, ax = plt.subplots(figsize=(6, 3.6), layout="constrained")
for kappa in curve["kappa"].values:
    ax.plot(curve["theta_v"], curve.sel(kappa=kappa), marker="o", label=f"kappa = {kappa:+.2f} mm^-1")
ax.set_xlabel("view elevation theta_v (deg), view azimuth 180 deg")
ax.set_ylabel("reflectance, G (1/sr)")
ax.legend(fontsize="small")
plt.show()
