"""A CD-BTF packed for the viewer's GPU: the tile mean's table asset plus the components and the weights.

A CD-BTF (:class:`cdbrdf.CDBTF`) is ``B(u, v, d) = mean(d) + sum_i w_i(u, v)
basis_i(d)``. Its asset is the :func:`~cdbrdf.view.asset.table_asset` of
the tile mean (the mosaic, the polar slice, the meshes without UVs and the
*tile mean* mode look that up as any table) with two more blocks and a
``btf`` entry in the header:

- ``components``: the mean and the leading ``rank`` components looked up
  together (:meth:`cdbrdf.CDBTF.lookup_grid`, the pole rule already applied)
  as an RGBA texture array, one layer per curvature, packed like the table's
  texture with ``1 + rank`` texels per sample: texel
  ``i = sample * (1 + rank) + component`` (``sample = row * columns + column``
  of the Fig. 7 image, component 0 the mean) lies at ``(i % width, i // width)``.
  float32, or float16 when the float32 texture is larger than
  :data:`~cdbrdf.view.asset.FLOAT16_ABOVE_BYTES` (``precision="auto"``);
- ``weights``: float32 RGBA texture array ``(layers, n_v, n_u, 4)``, layer
  ``j`` holding components ``4 j .. 4 j + 3`` of every texel (zero padded).

A neural CD-BTF (``btf.neural``) adds ``latents`` (RGBA32F, the codes of
every pyramid level in groups of four numbers, folded into rows) and
``decoder`` (RGBA32F, a row per neuron: its weights in groups of four, the
first layer's code part and feature part each padded to whole groups and the
hidden layers to multiples of four neurons, then the bias) and the header's
``btf.neural``; the shader computes the modulation of the mean as
:func:`cdbrdf.btf._neural.neural_at` does, the pyramid level from the
pixel's footprint (``dFdx``/``dFdy`` of the fabric position).

The shader decodes ``mean + sum_i w_i(u, v) basis_i`` at each pixel with the
lookup rule of the table (:mod:`cdbrdf.interp`) and periodic bilinear weights
between texel centres, as :meth:`cdbrdf.CDBTF.evaluate`. Components are
ordered by energy: when not all fit the GPU's guaranteed texture size (or
``max_rank`` asks for fewer) the leading ones are kept and the header says
``rank`` used of ``rank_total``.
"""

from __future__ import annotations

import logging
from collections.abc import Mapping
from typing import Any

import numpy as np

from ..btf._neural import level_shapes
from ..errors import LimitError, OptionError
from .asset import WEBGL2_MIN_LIMITS, Asset, _Blob, _precision, check_texture, table_asset

__all__ = ["btf_asset", "btf_rank_that_fits"]

_LOG = logging.getLogger(__name__)


def btf_rank_that_fits(btf: Any, *, limits: Mapping[str, int] = WEBGL2_MIN_LIMITS) -> int:
    """The most leading components whose texture fits ``limits`` (at most the BTF's rank).

    Parameters
    ----------
    btf
        The :class:`cdbrdf.CDBTF`.
    limits
        The GPU's limits by WebGL name (default: WebGL2's guaranteed ones).

    Returns
    -------
    int
        The rank: ``samples per curvature * (1 + rank) <= MAX_TEXTURE_SIZE^2``
        and ``ceil(rank / 4) <= MAX_ARRAY_TEXTURE_LAYERS``.
    """
    tex = int(limits["MAX_TEXTURE_SIZE"])
    lay = int(limits["MAX_ARRAY_TEXTURE_LAYERS"])
    samples = int(np.prod(btf.mean().lookup_grid().shape[1:5]))
    by_size = (tex * tex) // samples - 1
    return int(max(0, min(btf.rank, by_size, 4 * lay)))


def btf_asset(btf: Any, *, name: str = "btf", precision: str = "auto", max_rank: int | None = None,
              limits: Mapping[str, int] = WEBGL2_MIN_LIMITS) -> Asset:
    """Pack a CD-BTF for the viewer (see the module docstring for the layout).

    Parameters
    ----------
    btf
        A :class:`cdbrdf.CDBTF` with 1 (grey) or 3 (RGB) channels.
    name
        Its label in the viewer (the file name).
    precision
        One of :data:`~cdbrdf.view.asset.PRECISIONS`: the components' float type.
    max_rank
        Use at most this many leading components (default: all that fit).
    limits
        The GPU's limits by WebGL name (default: WebGL2's guaranteed ones).

    Returns
    -------
    Asset
        The tile mean's table asset, ``kind`` ``"btf"``, with the blocks
        ``components`` and ``weights`` and the header's ``btf`` entry.

    Raises
    ------
    OptionError
        For a negative ``max_rank``, other channel counts, an unknown precision.
    LimitError
        When the tile mean or the texel grid exceed the texture limits.
    """
    if max_rank is not None and (isinstance(max_rank, bool) or not isinstance(max_rank, int) or max_rank < 0):
        raise OptionError(f"rank: expected a whole number >= 0, got {max_rank!r}")
    mean = btf.mean()
    check_texture(mean, name=name, limits=limits)
    base = table_asset(mean, name=name, precision=precision)
    nu, nv = btf.texels
    tex = int(limits["MAX_TEXTURE_SIZE"])
    if nu > tex or nv > tex:
        raise LimitError(f"{name}: {nu} x {nv} texels per repeat exceed the GPU's MAX_TEXTURE_SIZE {tex}")
    total = int(btf.rank)
    fits = btf_rank_that_fits(btf, limits=limits)
    rank = fits if max_rank is None else min(fits, max_rank)
    err_used = btf.compression.get("relative_rms_error")
    if rank < total:
        why = (f"--rank {max_rank}" if max_rank is not None and max_rank <= fits
               else f"the GPU's guaranteed texture size (MAX_TEXTURE_SIZE {tex}) holds {fits}")
        err_used = btf.truncated(rank).compression["relative_rms_error"]
        _LOG.info("%s: the viewer uses the leading %d of %d components (%s; relative RMS error %.2f %%)", name,
                  rank, total, why, 100 * err_used)
    lg = btf.lookup_grid()
    nc = int(btf.n_channels)
    k = lg.shape[0]
    samples = int(np.prod(lg.shape[1:5]))
    per = 1 + rank
    comps = np.asarray(lg.values, dtype=np.float32).reshape(k, samples, 1 + total, nc)[:, :, :per]
    rgba = np.zeros((k, samples * per, 4), dtype=np.float32)
    rgba[..., :3] = comps.reshape(k, samples * per, nc) if nc == 3 else comps.reshape(k, samples * per, 1)
    rgba[..., 3] = 1.0
    n = samples * per
    width = min(n, tex)
    height = -(-n // width)
    prec = _precision(rgba.reshape(k, 1, 1, 1, n, 4), precision)
    folded = np.zeros((k, width * height, 4), dtype=np.float32)
    folded[:, :n] = rgba
    layers = max(1, -(-rank // 4))
    w = np.zeros((layers * 4, nv, nu), dtype=np.float32)
    w[:rank] = np.moveaxis(np.asarray(btf.weights, dtype=np.float32)[..., :rank], -1, 0)
    blob = _Blob()
    blob.parts, blob.size, blob.blocks = [base.blob], len(base.blob), dict(base.header["blocks"])
    blob.add("components", folded.reshape(k, height, width, 4), "float16" if prec == "float16" else "float32")
    # (layer, v, u, 4): RGBA of layer j = components 4j .. 4j+3
    blob.add("weights", np.moveaxis(w.reshape(layers, 4, nv, nu), 1, -1), "float32")
    neural = None if btf.neural is None else _neural_blocks(btf, blob, name=name, tex=tex)
    header = dict(base.header)
    header["kind"] = "btf"
    header["blocks"] = blob.blocks
    su, sv = btf.repeat_mm
    err = btf.compression.get("relative_rms_error")
    header["btf"] = {
        "rank": rank, "rank_total": total, "rank_fits": fits, "texels": [nu, nv], "repeat_mm": [su, sv],
        "levels": len(level_shapes(nu, nv)),
        "relative_rms_error": None if err is None else float(err),
        "relative_rms_error_used": None if err_used is None else float(err_used),
        "components": {"width": width, "height": height, "layers": k, "per_sample": per,
                       "format": "RGBA", "type": prec},
        "weights": {"width": nu, "height": nv, "layers": layers, "format": "RGBA", "type": "float32"},
        "neural": neural,
    }
    return Asset(header, blob.bytes())


def _neural_blocks(btf: Any, blob: _Blob, *, name: str, tex: int) -> dict[str, Any]:
    """Add the ``latents`` and ``decoder`` blocks of a neural CD-BTF; its header entry."""
    from ..btf._neural import N_FEATURES

    net = btf.neural
    if len(net.weights) != 3:
        raise OptionError(f"{name}: the viewer decodes decoders of two hidden layers; this one has layers {net.layers}")
    dims = net.latent_dims
    groups = -(-dims // 4)
    if groups > 8 or max(net.layers[1:3]) > 128:
        raise OptionError(f"{name}: the viewer decodes codes of at most 32 numbers and hidden layers of at most 128 "
                          f"(layers {net.layers})")
    codes = np.concatenate([z.reshape(-1, dims) for z in net.latents])
    lat = np.zeros((codes.shape[0], groups * 4), np.float32)
    lat[:, :dims] = codes
    flat = lat.reshape(-1, 4)
    width = min(flat.shape[0], tex)
    height = -(-flat.shape[0] // width)
    padded = np.zeros((width * height, 4), np.float32)
    padded[: flat.shape[0]] = flat
    blob.add("latents", padded.reshape(height, width, 4), "float32")
    w0, w1, w2 = (np.asarray(w, np.float32) for w in net.weights)
    b0, b1, b2 = (np.asarray(b, np.float32) for b in net.biases)
    h1, h2, nc = -(-w0.shape[1] // 4) * 4, -(-w1.shape[1] // 4) * 4, w2.shape[1]
    gin = groups + 3
    cols = max(gin, h1 // 4, h2 // 4) + 1
    rows = np.zeros((h1 + h2 + nc, cols * 4), np.float32)
    rows[: w0.shape[1], :dims] = w0[:dims].T
    rows[: w0.shape[1], 4 * groups : 4 * groups + N_FEATURES] = w0[dims:].T
    rows[: w0.shape[1], 4 * gin] = b0
    rows[h1 : h1 + w1.shape[1], : w1.shape[0]] = w1.T
    rows[h1 : h1 + w1.shape[1], 4 * (h1 // 4)] = b1
    rows[h1 + h2 :, : w2.shape[0]] = w2.T
    rows[h1 + h2 :, 4 * (h2 // 4)] = b2
    blob.add("decoder", rows.reshape(rows.shape[0], cols, 4), "float32")
    levels, first = [], 0
    for z in net.latents:
        levels.append([int(z.shape[1]), int(z.shape[0]), first])
        first += int(z.shape[0] * z.shape[1])
    g = btf.grid
    nu, nv = btf.texels
    return {"latents": {"width": width, "height": height, "groups": groups},
            "decoder": {"width": cols, "height": rows.shape[0]}, "levels": levels,
            "layers": [gin, h1, h2, nc], "constants": [float(c) for c in net.constants],
            "clamp": [float(g.theta_v[0]), float(g.theta_v[-1]), float(g.theta_l[0]), float(g.theta_l[-1])],
            "texel_mm": max(btf.repeat_mm[0] / nu, btf.repeat_mm[1] / nv)}
