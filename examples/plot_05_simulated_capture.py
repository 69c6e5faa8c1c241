"""
Measure a simulated capture
===========================

The measurement path of the paper on a coarse grid: the simulated rig
(:func:`cdbrdf.rig.simulate_capture`) photographs a known fabric on three
cylindrical stands (concave, flat, convex) with Mitsuba 3, writing a capture
folder with its plan (``capture.csv``, ``stands.json``), dark and white
frames and 16-bit PNG photographs with sensor noise;
:func:`cdbrdf.measure.measure` turns the folder back into a table (the 7 x 7
patch at the stand's centre, calibrated against the white frames, the
directions a concave stand hides filled from the other stands). The measured
table is compared with the ground truth it was photographed from.
"""

import tempfile
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

import cdbrdf.materials
from cdbrdf import Grid
from cdbrdf.measure import measure
from cdbrdf.plot import plot_mosaic
from cdbrdf.rig import RigOptions, simulate_capture

truth = cdbrdf.materials.load("denim")
grid = Grid(kappa=[-0.22, 0.0, 0.22], theta_l=[15.0, 45.0], phi_l=[0.0, 180.0],
            theta_v=[0.0, 30.0, 60.0], phi_v=[0.0, 180.0])
work = tempfile.TemporaryDirectory()  # removed when the example ends
folder = Path(work.name) / "capture"
report = simulate_capture(truth, folder, RigOptions(size=16, field_mm=1.0, seed=1), grid=grid)
print(f"{report.n_images} photographs and {report.n_white} white frames in {report.seconds_rendering:.1f} s")

# %%
# Measure the folder. The photographs are read as Dask tasks; a capture this
# small is read in this process (``scheduler="synchronous"``). The call
# returns the table and a report of what was read and filled.
table, measured = measure(folder, scheduler="synchronous", checkpoint=False)
print(table)
print(f"{table.measured.mean():.0%} of the samples photographed, the rest filled")

# %%
# The measured table against the truth at the same samples.
m = grid.mesh()
expected = truth.evaluate(m["theta_v"], m["phi_v"], m["theta_l"], m["phi_l"], m["kappa"])
relative = np.abs(table.values / expected - 1.0)
print(f"median relative difference to the truth: {np.median(relative[table.measured]):.2%} (photographed samples)")

fig = plt.figure(figsize=(8.0, 5.6), layout="constrained")
plot_mosaic(table, fig=fig, panel_size_in=2.2, dpi=80)
plt.show()
