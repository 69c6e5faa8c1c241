"""
The paper's Fig. 7 mosaic
=========================

Fig. 7 of Matsufuji & Kawai lays a table out as one image per curvature:
each image tiles the view directions for every light direction, all at one
exposure, and a last panel shows where a bend changes the colour.
:func:`cdbrdf.plot.plot_mosaic` draws it; :meth:`cdbrdf.CDBRDF.fig7` gives
the values in that layout.
"""

import matplotlib.pyplot as plt

import cdbrdf.materials
from cdbrdf.plot import plot_mosaic

table = cdbrdf.materials.load("shot")
layout = table.fig7()
print("curvatures x light directions x view directions x channels:", layout.shape)

# %%
# The curvatures of the paper's stands (mm^-1): concave, flat and convex.
fig = plt.figure(figsize=(8.0, 5.6), layout="constrained")
plot_mosaic(table, kappa=[-0.22, 0.0, 0.22], fig=fig, panel_size_in=2.4, dpi=80)
plt.show()
