"""
Wrinkles from a normal map, looked up per shading point
=======================================================

The bends that change how cloth looks are finer than production meshes:
they live in normal maps. cdbrdf bakes a map's curvature per texel
(:class:`cdbrdf.mesh.CurvatureMap`, prefiltered levels), and the plug-in
looks it up at every shading point: its normals tilt the shading, its
curvature (1/mm, at the UV scale) is added to the mesh's and picks the
table's slice. Here a 100 x 100 mm quad of two triangles carries sine
wrinkles (period 10 mm, amplitude 0.4 mm: 0.158 / mm at the crests) at a UV
scale of 100 mm, in the bundled shot fabric under the paper's light: the
plain BRDF and the CDBRDF differ at the crests and troughs, as they do on
the same wrinkles modelled as geometry.
"""

from dataclasses import replace

import matplotlib.pyplot as plt
import numpy as np

import cdbrdf.materials
from cdbrdf.colour import delta_e_ab, ev_to_factor, linear_to_lab, srgb_encode
from cdbrdf.mesh import Mesh, SurfaceMaps, normal_map_from_normals
from cdbrdf.render import Camera, Light, Picture, RenderSpec, render_table

A, L, S = 0.4, 10.0, 100.0  # mm: amplitude, period, the quad's side
t = (np.arange(512) + 0.5) / 512 * S
slope = A * 2 * np.pi / L * np.cos(2 * np.pi * t / L)  # dh/dx across u
normals = np.zeros((512, 512, 3))
normals[..., 0], normals[..., 2] = -slope[None, :], 1.0
wrinkles = normal_map_from_normals(normals / np.linalg.norm(normals, axis=-1, keepdims=True), name="wrinkles")

v = np.array([[0, 0, 0], [S, 0, 0], [S, S, 0], [0, S, 0]], dtype=float)
quad = Mesh(v, np.array([[0, 1, 2], [0, 2, 3]]), None, v[:, :2] / S)

shot = cdbrdf.materials.load("shot")
bare_spec = RenderSpec(surface=quad, modes=("brdf", "cdbrdf"), size=(160, 160), spp=32, light=Light(lighting="paper"),
                       camera=Camera(view=(60.0, -90.0)))  # 60 degrees above the quad
mapped = render_table(shot, replace(bare_spec, maps=SurfaceMaps(normal_map=wrinkles, uv_scale=S)))
bare = render_table(shot, bare_spec)
for note in mapped.mesh.metadata["notes"]:
    if "UV scale" in note or "wrinkles" in note:
        print(note)


def shown(pic: Picture, mode: str) -> np.ndarray:
    """What the screen shows of one mode: linear values at the picture's exposure, clipped to white."""
    return np.clip(pic.display(mode) * ev_to_factor(pic.exposure_ev), 0, 1)


def difference(pic: Picture) -> tuple[np.ndarray, float]:
    """Delta E*ab per pixel between the two modes (NaN off the quad), and its 95th percentile."""
    d = delta_e_ab(linear_to_lab(shown(pic, "brdf")), linear_to_lab(shown(pic, "cdbrdf")))
    seen = pic.images["brdf"][..., 3] > 0.99
    return np.where(seen, d, np.nan), float(np.percentile(d[seen], 95))


d_map, p95_map = difference(mapped)
d_bare, p95_bare = difference(bare)
print(f"BRDF vs CDBRDF, p95 Delta E*ab: with the map {p95_map:.2f}, without {p95_bare:.2f}")

# %%
# The plain BRDF and the CDBRDF on the mapped quad, and where they differ.
fig, axes = plt.subplots(1, 3, figsize=(9, 3.3), layout="constrained")
axes[0].imshow(srgb_encode(shown(mapped, "brdf")))
axes[0].set_title("plain BRDF")
axes[1].imshow(srgb_encode(shown(mapped, "cdbrdf")))
axes[1].set_title("CDBRDF")
im = axes[2].imshow(d_map, cmap="magma", vmin=0, vmax=8)
axes[2].set_title(f"Delta E*ab (p95 {p95_map:.1f})")
fig.colorbar(im, ax=axes[2], shrink=0.8)
for ax in axes:
    ax.set_axis_off()
plt.show()
