"""
Render the sine sheet: plain BRDF against CDBRDF
================================================

The paper's Figs. 9-10: a sheet bent like a sine wave, lit by one
directional light, rendered in Mitsuba 3 with the plain BRDF (the kappa = 0
slice everywhere) and with the CDBRDF (the table looked up at the curvature
of every point). :func:`cdbrdf.render.render_table` makes both pictures with
the same samples and one exposure; the difference shows up only where the
sheet bends. A small image and few samples per pixel keep this quick.
"""

import matplotlib.pyplot as plt

import cdbrdf.materials
from cdbrdf.plot import plot_render_comparison
from cdbrdf.render import RenderSpec, render_table

table = cdbrdf.materials.load("shot")
picture = render_table(table, RenderSpec(surface="sine", modes=("brdf", "cdbrdf"), size=(192, 144), spp=8))
print(picture.surface, "lit by", picture.lighting, "light at", picture.light)
print("exposure (EV):", round(picture.exposure_ev, 2))

# %%
# The images are linear RGBA float32 arrays, one per mode.
brdf, cdbrdf_image = picture.images["brdf"], picture.images["cdbrdf"]
print(brdf.shape, brdf.dtype)

fig = plt.figure(figsize=(9.0, 3.0), layout="constrained")
plot_render_comparison(brdf[..., :3], cdbrdf_image[..., :3], exposure_ev=picture.exposure_ev, fig=fig)
plt.show()
