"""
Load a material and look up its reflectance
===========================================

The bundled denim table is a :class:`cdbrdf.CDBRDF`: linear RGB reflectance
(sr^-1) over the view direction, the light direction and the surface
curvature kappa (mm^-1; > 0 convex). :meth:`~cdbrdf.CDBRDF.evaluate` looks
it up by 5-D multilinear interpolation and broadcasts like NumPy;
:func:`cdbrdf.plot.plot_slice` draws the reflectance along the plane of
incidence, one curve per measured curvature.
"""

import matplotlib.pyplot as plt
import numpy as np

import cdbrdf.materials
from cdbrdf.plot import plot_slice

table = cdbrdf.materials.load("denim")
print(table)

# %%
# One lookup: view at 40 degrees elevation, light at 30 degrees from the
# opposite side, on a convex bend of 0.1 mm^-1 (a 10 mm radius).
rgb = table.evaluate(theta_v=40, phi_v=90, theta_l=30, phi_l=270, kappa=0.1)
print("RGB:", np.round(rgb, 4))

# %%
# The same direction over a range of curvatures: the arguments broadcast,
# the result has one trailing axis for the channels.
kappa = np.linspace(-0.2, 0.2, 5)
print(np.round(table.evaluate(theta_v=40, phi_v=90, theta_l=30, phi_l=270, kappa=kappa), 4))

# %%
# The plain BRDF is the flat slice (kappa = 0) of the same table.
flat = table.brdf()
print("kappa axis of the plain BRDF:", flat.grid.kappa)

# %%
# Reflectance along the plane of incidence for a light at 45 degrees.
fig, ax = plt.subplots(figsize=(6, 3.6), layout="constrained")
plot_slice(table, theta_l_deg=45.0, phi_l_deg=0.0, channel="G", ax=ax)
plt.show()
