"""
A swatch at a glance, and a close-up of a fold
==============================================

Two ways to look at a material where it bends. The **swatch**
(``cdbrdf render --scene swatch``, :class:`cdbrdf.mesh.Swatch`) is a piece
of cloth laid in folds of known radii, 20, 10, 5 and 3 mm, each made of
circular arcs so that its curvature is exact: under the plain BRDF every
fold shows the same colours (all turn through the same angles), so what
changes from fold to fold is the curvature's doing. The comparison's heat
map is the colour difference of the two pictures as they are shown, in
CIEDE2000, the textile trade's tolerance metric (about 1 is just
noticeable).

A **close-up** is a :class:`cdbrdf.render.Camera`: ``look_at`` a point (in
the mesh's own coordinates and unit) or an anchor such as ``"crest"`` (the
tightest convex fold facing the camera), ``zoom`` a magnification about
the framed view (2 halves what is seen). Small images and few samples keep
this quick.
"""

import matplotlib.pyplot as plt
import numpy as np

import cdbrdf.materials
from cdbrdf.colour import tonemap_srgb8
from cdbrdf.mesh import Skirt, Swatch, skirt_mesh
from cdbrdf.plot import displayed_delta_e, plot_render_comparison
from cdbrdf.render import Camera, RenderSpec, render_table

table = cdbrdf.materials.load("shot")
swatch = Swatch()
pic = render_table(table, RenderSpec(surface=swatch, modes=("brdf", "cdbrdf"), size=(240, 168), spp=8,
                                     curvature_image=True))
print(pic.surface, "in the", pic.lighting, "lighting; exposure", round(pic.exposure_ev, 2), "EV")

fig = plt.figure(figsize=(9.0, 2.6), layout="constrained")
plot_render_comparison(pic.display("brdf"), pic.display("cdbrdf"), exposure_ev=pic.exposure_ev, fig=fig)
plt.show()

# %%
# The colour difference on each fold's crest: the pixels that see
# kappa = 1 / R (``pic.curvature``, mm^-1). The table spans +-0.22 mm^-1,
# so the 3 mm fold (0.33 mm^-1) is looked up at the table's edge.
de = displayed_delta_e(pic.display("brdf"), pic.display("cdbrdf"), exposure_ev=pic.exposure_ev)
for r in swatch.radii_mm:
    crest = np.isclose(pic.curvature, 1.0 / r, rtol=0.02)
    print(f"fold of radius {r:4.1f} mm: {crest.sum():4d} crest pixels, median CIEDE2000 {np.median(de[crest]):.2f}")

# %%
# A skirt (Y-up, mm, as a fashion CAD tool exports it), framed whole, then
# five times closer on its tightest convex fold; both under the studio
# lighting, whose key light follows the camera.
skirt = skirt_mesh(Skirt(around=81, down=61, sash=False))
views = {"framed": Camera(), "look_at='crest', zoom=5": Camera(look_at="crest", zoom=5.0)}
fig, axes = plt.subplots(1, 2, figsize=(7.0, 4.0), layout="constrained")
for ax, (title, camera) in zip(axes, views.items()):
    shot = render_table(table, RenderSpec(surface=skirt, size=(160, 192), spp=8, camera=camera))
    ax.imshow(tonemap_srgb8(shot.display(), exposure_ev=shot.exposure_ev))
    ax.set_title(title, fontsize=10)
    ax.set_axis_off()
plt.show()
