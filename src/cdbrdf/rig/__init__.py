"""The simulated capture rig: Mitsuba 3 photographs of a fabric on the paper's stands.

A stage of its own beside :mod:`cdbrdf.synth` (which makes the materials)
and :mod:`cdbrdf.measure` (which measures photographs): it turns a material
and a capture plan into a capture folder with a known truth. For every row
of a plan (``docs/capture.md``) the rig renders one photograph with the
row's camera and light:

- the stand's centre is the origin; its face's normal there is +z, the
  bending direction +x, the cylinder axis y (the conventions' local frame);
- the fabric (the ``cdbrdf`` BSDF plug-in of :mod:`cdbrdf.render`, with the
  stand's curvature as a constant) covers the face: the outside of a cylinder
  (``kappa > 0``), a flat face, or the inside of a trough (``kappa < 0``)
  of :class:`~cdbrdf.measure.stands.Stand` geometry, whose edges carry white
  walls; the rest of the stand body is white (diffuse, reflectance 0.8);
- the camera is orthographic, looks at the centre from the row's view
  direction, ``field_mm`` wide, and is shifted so that the centre falls on
  the middle of pixel ``(size // 2, size // 2)``; each pixel integrates its
  footprint with ``spp`` stratified samples and a box filter;
- one directional light of unit irradiance comes from the row's light
  direction; the ``direct`` integrator traces shadow rays, so on a concave
  stand the walls and the trough shadow the centre at grazing light, and at
  grazing views the camera sees the trough or a wall instead of the centre:
  the paper's artefact appears by itself;
- white-reference rows render a flat Lambertian plate of albedo
  ``white_albedo``; dark rows render nothing (noise only);
- the linear pixel value ``x = gain * exposure * L`` is turned into
  electrons ``x * full_well``, gets photon (Poisson) and read (Gaussian)
  noise, is clipped to [0, 1], sRGB-encoded and quantised (16-bit PNG by
  default; 8-bit PNG, 16-bit TIFF, or linear float OpenEXR without clipping).

Modules, one per job:

- :mod:`~cdbrdf.rig.stands`: triangle meshes of the stands, rays meeting the face;
- :mod:`~cdbrdf.rig.camera`: the camera and light transforms, and
  :func:`expected_patch_value` (the ideal measurement of one photograph);
- :mod:`~cdbrdf.rig.scenes`: the Mitsuba scenes (one per stand, loaded once;
  the camera and light are moved between renders);
- :mod:`~cdbrdf.rig.sensor`: noise, quantisation, the image files;
- :mod:`~cdbrdf.rig.options`: :class:`RigOptions`, how the rig photographs
  (image size, field, samples, noise, gain, exposures, image kind, white
  reference, seed), checked once, with the ranges the command line reads;
- :mod:`~cdbrdf.rig.simulate`: :func:`simulate_capture`, the whole folder.

Importing the package loads neither Mitsuba nor the renderer.
"""

from __future__ import annotations

from .camera import expected_patch_value
from .options import RigOptions
from .scenes import STAND_REFLECTANCE
from .sensor import IMAGE_KINDS, NoiseModel
from .simulate import SimulationReport, load_material, simulate_capture
from .stands import stand_meshes

__all__ = [
    "simulate_capture",
    "RigOptions",
    "SimulationReport",
    "NoiseModel",
    "load_material",
    "stand_meshes",
    "expected_patch_value",
    "IMAGE_KINDS",
    "STAND_REFLECTANCE",
]
