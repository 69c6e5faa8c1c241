"""
Curvature of a mesh
===================

The CDBRDF is looked up at the curvature of every point of a surface.
:func:`cdbrdf.mesh.surface_curvature` repairs a triangle mesh and fits its
curvatures (mm^-1, > 0 convex) over a patch the size of the one the table
was measured from; the renderer reads them as vertex attributes.

Two surfaces: the paper's sine sheet, whose curvature across the waves is
known in closed form (:func:`cdbrdf.mesh.sine_sheet_curvature`), and a cloth
draped over a dome (:func:`cdbrdf.mesh.draped_cloth_mesh`): convex on the
dome and the fold crests, concave in the fold valleys.
"""

import matplotlib.pyplot as plt
import numpy as np

from cdbrdf.mesh import (
    DrapedCloth,
    SineSheet,
    draped_cloth_mesh,
    sine_sheet_curvature,
    sine_sheet_mesh,
    surface_curvature,
)
from cdbrdf.plot import plot_curvature_map

sheet = SineSheet(width_mm=40.0, depth_mm=20.0, vertices_per_wavelength=24)
meshes = {
    "sine sheet": sine_sheet_mesh(sheet),
    "draped cloth": draped_cloth_mesh(DrapedCloth(resolution=61)),
}

surfaces = []
for name, mesh in meshes.items():
    fit = surface_curvature(mesh.vertices, mesh.faces, units="mm", neighbourhood_mm=2.0, frame=None, name=name)
    points = np.asarray(mesh.vertices)[fit.source]
    surfaces.append((name, points, fit.faces, fit.kappa))
    print(f"{name}: {len(fit.faces)} triangles, kappa from {fit.kappa.min():+.3f} to {fit.kappa.max():+.3f} mm^-1")

# %%
# The fitted curvature of the sheet against the closed form at the same
# points: crests convex (> 0), troughs concave (< 0), at most
# ``amplitude (2 pi / wavelength)^2`` = 0.197 mm^-1.
name, points, faces, kappa = surfaces[0]
exact = sine_sheet_curvature(points[:, 0], amplitude_mm=sheet.amplitude_mm, wavelength_mm=sheet.wavelength_mm)
print(f"sine sheet: median difference to the closed form {np.median(np.abs(kappa - exact)):.4f} mm^-1")

fig = plt.figure(figsize=(9.0, 4.0), layout="constrained")
plot_curvature_map(surfaces, limit=0.2, fig=fig)
plt.show()
