"""Helpers of the importer tests: the shared RGL files, analytic BRDFs, and files written in each format.

The real RGL files live in ``../shared/data/rgl/`` relative to the repository
root (``CDBRDF_SHARED_DATA`` points elsewhere, e.g. from a second checkout);
tests that need them skip when they are absent. MERL and UTIA files are
written by the tests from analytic BRDFs, in the formats' published layouts.
"""

from __future__ import annotations

import functools
from pathlib import Path

import numpy as np

from cdbrdf.importers import merl, utia
from cdbrdf.importers.source import Source

from .shared_data import shared_file

RGL_FILES = {"matte": "paper_white_rgb.bsdf", "satin": "satin_rosaline_rgb.bsdf", "glossy": "cc_ibiza_sunset_rgb.bsdf"}


def rgl_path(kind: str = "matte") -> Path:
    """One of the shared RGL files; skips the test when the shared data are absent."""
    return shared_file(f"rgl/{RGL_FILES[kind]}")


def need_mitsuba() -> None:
    from .lookup_cases import need_mitsuba as need

    need()


# -- analytic BRDFs (sr^-1) -------------------------------------------------------------------
def _vec(theta_deg, phi_deg):
    t, p = np.radians(theta_deg), np.radians(phi_deg)
    return np.stack([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)], axis=-1)


def lobe_brdf(theta_v, phi_v, theta_l, phi_l, *, kd=(0.2, 0.3, 0.5), ks=0.8, n=20.0):
    """Isotropic: Lambertian kd/pi + a Blinn-Phong lobe ks (n + 2)/(2 pi) cos(theta_h)^n, RGB ``(..., 3)``."""
    h = _vec(theta_v, phi_v) + _vec(theta_l, phi_l)
    h /= np.linalg.norm(h, axis=-1, keepdims=True)
    spec = ks * (n + 2) / (2 * np.pi) * np.clip(h[..., 2], 0, 1) ** n
    return np.asarray(kd) / np.pi + spec[..., None] * np.ones(3)


def aniso_brdf(theta_v, phi_v, theta_l, phi_l):
    """Anisotropic: a smooth function of both azimuths, RGB ``(..., 3)``, positive."""
    t = np.radians(theta_l)
    base = 0.1 + 0.05 * np.cos(np.radians(2 * phi_l)) * np.sin(t) + 0.02 * np.cos(np.radians(phi_v - 30.0))
    return base[..., None] * np.array([1.0, 0.8, 0.6]) + 0.03 * np.cos(np.radians(theta_v))[..., None]


def analytic_source(f, *, isotropic: bool, name: str = "analytic") -> Source:
    """A :class:`Source` evaluating ``f(theta_v, phi_v, theta_l, phi_l)``."""
    return Source(path=Path(name), format="test", symmetry="isotropic" if isotropic else "anisotropic",
                  quantity="brdf", colour_space="linear Rec.709 (sRGB primaries)", material=name, description="",
                  details={}, evaluate=lambda tv, pv, tl, pl: (f(tv, pv, tl, pl), None), sha256="0")


# -- files --------------------------------------------------------------------------------------
def merl_centres():
    """Directions (theta_v, phi_v, theta_l, phi_l in degrees) of every MERL sample centre, ``(90, 90, 180)`` each.

    The light is at phi_l = 0: the half vector in the x-z plane at theta_h, the
    difference vector at (theta_d, phi_d), as the MERL reader's inverse.
    """
    nh, nd, npd = merl.DIMS
    th = (np.arange(nh) + 0.5) / nh
    th = th**2 * np.pi / 2
    td = (np.arange(nd) + 0.5) / nd * np.pi / 2
    pd = (np.arange(npd) + 0.5) / npd * np.pi
    TH, TD, PD = np.meshgrid(th, td, pd, indexing="ij")
    d = np.stack([np.sin(TD) * np.cos(PD), np.sin(TD) * np.sin(PD), np.cos(TD)], axis=-1)
    # rotate d back: by +theta_h about y, then (phi_h = 0) nothing about z
    c, s = np.cos(TH), np.sin(TH)
    lx, ly, lz = c * d[..., 0] + s * d[..., 2], d[..., 1], -s * d[..., 0] + c * d[..., 2]
    light = np.stack([lx, ly, lz], axis=-1)
    h = np.stack([np.sin(TH), np.zeros_like(TH), np.cos(TH)], axis=-1)
    view = 2 * np.sum(light * h, axis=-1, keepdims=True) * h - light
    tl = np.degrees(np.arccos(np.clip(light[..., 2], -1, 1)))
    pl = np.degrees(np.arctan2(light[..., 1], light[..., 0]))
    tv = np.degrees(np.arccos(np.clip(view[..., 2], -1, 1)))
    pv = np.degrees(np.arctan2(view[..., 1], view[..., 0]))
    return tv, pv, tl, pl


@functools.cache
def _merl_bytes() -> bytes:
    """The bytes of the lobe BRDF's MERL file (made once per process)."""
    import tempfile

    tv, pv, tl, pl = merl_centres()
    vals = lobe_brdf(tv, pv, tl, pl)
    vals = np.where(((tv >= 90) | (tl >= 90))[..., None], -1.0 * np.array(merl.SCALES), vals)
    with tempfile.TemporaryDirectory() as tmp:
        p = Path(tmp) / "x.binary"
        merl.write(p, vals)
        return p.read_bytes()


def write_merl(path):
    """A MERL ``.binary`` file of :func:`lobe_brdf` at the sample centres; directions below the horizon stored as -1."""
    Path(path).write_bytes(_merl_bytes())
    return Path(path)


def write_utia(path, f=aniso_brdf, *, encoding="srgb"):
    """A UTIA ``.bin`` file of ``f`` at its sample directions (values in [0, 1], as the database's)."""
    ti, pi, tv, pv = np.meshgrid(utia.THETA_DEG, utia.PHI_DEG, utia.THETA_DEG, utia.PHI_DEG, indexing="ij")
    utia.write(path, f(tv, pv, ti, pi), encoding=encoding)
    return path
