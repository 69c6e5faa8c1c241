"""
How much a bend changes a fabric's colour
=========================================

:func:`cdbrdf.synth.metrics.bend_contrast` measures what the eye sees when
the cloth bends: the median CIE 1976 colour difference Delta E*ab, near the
surface normal, between a curvature and the flat cloth, with the mean colour
at each curvature as swatches. It is the number the bundled fabrics'
calibration is judged by: denim lightens on a convex bend (the weave opens
and shows the white weft), shot fabric changes colour.
"""

import matplotlib.pyplot as plt
import numpy as np

import cdbrdf.materials
from cdbrdf.synth.metrics import bend_contrast

kappas = [-0.22, -0.13, 0.13, 0.22]  # mm^-1, the paper's stands
rows = []
for name in cdbrdf.materials.names():
    table = cdbrdf.materials.load(name)
    results = [bend_contrast(table, k, n_pairs=4000) for k in kappas]
    rows.append((name, results))
    for r in results:
        change = f"Delta E*ab {r.median_delta_e:4.1f}, Delta L* {r.lightness_change:+5.1f}"
        print(f"{name:6s} kappa {r.kappa:+.2f} mm^-1: {change}")

# %%
# Swatches: the flat colour, then each curvature, with its Delta E*ab.
fig, axes = plt.subplots(len(rows), 1, figsize=(7, 1.4 * len(rows)), layout="constrained", squeeze=False)
for ax, (name, results) in zip(axes[:, 0], rows):
    swatches = [results[0].swatches_srgb8()[1]] + [r.swatches_srgb8()[0] for r in results]
    ax.imshow(np.array(swatches)[None], aspect="auto")
    ax.set_xticks(range(len(swatches)), ["flat"] + [f"{r.kappa:+.2f}\ndE {r.median_delta_e:.1f}" for r in results])
    ax.set_yticks([])
    ax.set_title(name, loc="left")
plt.show()
