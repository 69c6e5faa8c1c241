"""The neural CD-BTF: per-texel latent codes (a mip pyramid) and one small decoder modulating the tile mean.

A texel's reflectance is the tile mean ``M`` (a CDBRDF, looked up by the rule
of :mod:`cdbrdf.interp`) times a modulation that a small multilayer
perceptron computes from the texel's latent code ``z`` and the query::

    B(u, v, d) = max(0, M(d) * (1 + o(z(u, v), phi(d))))

``phi(d)`` (:func:`features`) is fixed: the light, view and half-vector
directions (9 numbers, the elevations clamped to the grid's axes), the
curvature (clamped, over the axis' largest magnitude) and the logarithm of the
tile mean's luminance at the query (which tells the decoder where the mean's
own highlights lie). The network has ReLU hidden layers and a linear output
of one value per channel.

The latent codes live on a pyramid of texel grids: level 0 is the CD-BTF's
``n_u x n_v`` texels, level ``l`` about ``n / 2^l`` texels per side (block
means of the texels are its training targets), up to 2 x 2; beyond the last
level the modulation fades to zero, so far away the CD-BTF *is* its tile
mean. Between texel centres the codes are interpolated bilinearly
(periodically), between levels linearly, and decoded once (NeuMIP, Kuznetsov
et al. 2021): the level is ``log2`` of the footprint in texels.

The decoder and the codes are fitted together (an auto-decoder: the codes are
free parameters, started from the texels' leading principal components) by
Adam on random batches of (texel, sample) pairs, minimising the squared error
relative to each curvature slice's energy (the quantity recorded:
:func:`relative_errors`). Everything here is NumPy: the network is small
(a few thousand weights) and its batches are dense matrix products, which
NumPy's BLAS runs as fast as a deep-learning library would on the CPU, with
no new dependency and the same code for the fit and for the reference
inference (:meth:`Neural.modulation`). The renderer (Dr.Jit) and the viewer
(GLSL) evaluate the same network from its weights.
"""

from __future__ import annotations

import logging
import math
import time
from typing import TYPE_CHECKING, Any, NamedTuple

import numpy as np
from numpy.typing import NDArray

if TYPE_CHECKING:
    from ..grid import Grid

__all__: list[str] = []

_LOG = logging.getLogger(__name__)

#: Inputs of the decoder besides the latent code (:func:`features`).
N_FEATURES = 11

#: Luminance weights of the mean's log-luminance feature (Rec. 709, as cdbrdf.colour).
_LUM = np.array([0.2126, 0.7152, 0.0722])


class Neural(NamedTuple):
    """The neural part of a CD-BTF (private: :class:`cdbrdf.btf.CDBTF` holds it).

    ``latents``: one array per pyramid level, ``(n_v_l, n_u_l, latent_dims)``
    float32 (values representable in float16: the file stores float16);
    ``weights``/``biases``: the layers, ``W (n_in, n_out)``, ``b (n_out,)``;
    ``constants``: ``(kappa_scale, lum_epsilon, lum_offset)`` of :func:`features`.
    """

    latents: tuple[NDArray[np.float32], ...]
    weights: tuple[NDArray[np.float32], ...]
    biases: tuple[NDArray[np.float32], ...]
    constants: tuple[float, float, float]

    @property
    def latent_dims(self) -> int:
        return int(self.latents[0].shape[-1])

    @property
    def layers(self) -> list[int]:
        """Widths: inputs, hidden layers, outputs."""
        return [int(self.weights[0].shape[0])] + [int(w.shape[1]) for w in self.weights]

    @property
    def n_parameters(self) -> int:
        return int(sum(w.size + b.size for w, b in zip(self.weights, self.biases)))

    @property
    def n_latent_values(self) -> int:
        return int(sum(z.size for z in self.latents))

    def modulation(self, z: NDArray[np.floating], phi: NDArray[np.floating]) -> NDArray[np.float64]:
        """``o`` for codes ``z (n, L)`` and features ``phi (n, F)``: ``(n, channels)``."""
        x = np.concatenate([np.asarray(z, np.float32), np.asarray(phi, np.float32)], axis=-1)
        for i, (w, b) in enumerate(zip(self.weights, self.biases)):
            x = x @ w + b
            if i < len(self.weights) - 1:
                np.maximum(x, 0.0, out=x)
        return x.astype(np.float64)


def level_shapes(nu: int, nv: int) -> list[tuple[int, int]]:
    """``(n_v, n_u)`` of every pyramid level: halved (rounded up) until both are at most 2; at least level 0."""
    out = [(nv, nu)]
    while max(out[-1]) > 2:
        v, u = out[-1]
        out.append((max(1, -(-v // 2)), max(1, -(-u // 2))))
    return out


def block_means(values: NDArray[np.floating], shape: tuple[int, int]) -> NDArray[np.float32]:
    """Texels ``(n_v, n_u, ...)`` averaged onto a coarser periodic grid ``shape`` (each fine texel to the coarse one
    containing its centre)."""
    nv, nu = values.shape[:2]
    cv, cu = shape
    if (cv, cu) == (nv, nu):
        return np.asarray(values, np.float32)
    jv = ((np.arange(nv) + 0.5) * cv / nv).astype(np.int64)
    iu = ((np.arange(nu) + 0.5) * cu / nu).astype(np.int64)
    cell = (jv[:, None] * cu + iu[None, :]).reshape(-1)
    flat = np.asarray(values, np.float64).reshape(nv * nu, -1)
    out = np.zeros((cv * cu, flat.shape[1]))
    np.add.at(out, cell, flat)
    count = np.bincount(cell, minlength=cv * cu).astype(np.float64)
    return (out / count[:, None]).reshape((cv, cu) + values.shape[2:]).astype(np.float32)


def features(theta_v: NDArray[np.floating], phi_v: NDArray[np.floating], theta_l: NDArray[np.floating],
             phi_l: NDArray[np.floating], kappa: NDArray[np.floating], mean_rgb: NDArray[np.floating],
             constants: tuple[float, float, float]) -> NDArray[np.float32]:
    """The decoder's inputs besides the code, ``(n, N_FEATURES)`` float32 (angles in degrees, already clamped).

    ``l`` (3), ``v`` (3), ``h = normalize(l + v)`` (3), ``kappa / kappa_scale``,
    ``log(lum(M) + eps) - offset`` (``mean_rgb``: the tile mean at the query,
    ``(n, channels)``; one channel is its own luminance).
    """
    ks, eps, off = constants
    tv, pv, tl, pl = (np.radians(np.asarray(a, np.float64)) for a in (theta_v, phi_v, theta_l, phi_l))
    v = np.stack([np.sin(tv) * np.cos(pv), np.sin(tv) * np.sin(pv), np.cos(tv)], -1)
    l = np.stack([np.sin(tl) * np.cos(pl), np.sin(tl) * np.sin(pl), np.cos(tl)], -1)
    h = l + v
    h /= np.maximum(np.linalg.norm(h, axis=-1, keepdims=True), 1e-12)
    m = np.asarray(mean_rgb, np.float64)
    lum = m @ _LUM if m.shape[-1] == 3 else m[..., 0]
    lm = np.log(np.maximum(lum, 0.0) + eps) - off
    k = np.asarray(kappa, np.float64) / ks
    return np.concatenate([l, v, h, k[..., None], lm[..., None]], axis=-1).astype(np.float32)


def feature_constants(kappa_axis: NDArray[np.floating],
                      mean_values: NDArray[np.floating]) -> tuple[float, float, float]:
    """``(kappa_scale, eps, offset)``: the curvature axis' largest magnitude (1 if 0), 1e-3 of the mean luminance,
    the mean of ``log(lum + eps)`` over the tile mean's samples."""
    ks = float(np.max(np.abs(kappa_axis))) or 1.0
    m = np.asarray(mean_values, np.float64).reshape(-1, mean_values.shape[-1])
    lum = m @ _LUM if m.shape[-1] == 3 else m[:, 0]
    eps = max(1e-3 * float(np.mean(np.maximum(lum, 0.0))), 1e-12)
    off = float(np.mean(np.log(np.maximum(lum, 0.0) + eps)))
    return ks, eps, off


class FitOptions(NamedTuple):
    """How :func:`fit` trains (the defaults are the measured choice, ``docs/btf.md``)."""

    latent_dims: int = 12
    hidden: tuple[int, ...] = (64, 64)
    steps: int = 1200
    epochs: float = 40.0
    texels_per_batch: int = 64
    samples_per_batch: int = 512
    learning_rate: float = 4e-3
    coarse_fraction: float = 0.25
    between: float = 0.5
    seed: int = 0


def _init_layers(rng: np.random.Generator, sizes: list[int]) -> tuple[list[np.ndarray], list[np.ndarray]]:
    ws, bs = [], []
    for i, (a, b) in enumerate(zip(sizes[:-1], sizes[1:])):
        last = i == len(sizes) - 2
        ws.append((np.zeros((a, b)) if last else rng.standard_normal((a, b)) * math.sqrt(2.0 / a)).astype(np.float32))
        bs.append(np.zeros(b, np.float32))
    return ws, bs


def _init_codes(rng: np.random.Generator, y: NDArray[np.float32], dims: int) -> NDArray[np.float32]:
    """Leading principal components of the texels ``y (T, S, C)`` on up to 4,096 columns, unit RMS each."""
    t = y.shape[0]
    flat = y.reshape(t, -1)
    cols = rng.choice(flat.shape[1], size=min(flat.shape[1], 4096), replace=False)
    x = flat[:, cols].astype(np.float64)
    x -= x.mean(axis=0)
    u = np.linalg.svd(x, full_matrices=False)[0] if t > 1 else np.zeros((1, 1))
    z = np.zeros((t, dims), np.float32)
    k = min(dims, u.shape[1])
    z[:, :k] = u[:, :k] * math.sqrt(t)
    return z


class _Adam:
    """Adam (Kingma & Ba 2015) over a list of float32 arrays, updated in place."""

    def __init__(self, params: list[np.ndarray], lr: float) -> None:
        self.params, self.lr, self.t = params, lr, 0
        self.m = [np.zeros_like(p) for p in params]
        self.v = [np.zeros_like(p) for p in params]

    def step(self, grads: list[np.ndarray], scale: float) -> None:
        self.t += 1
        b1, b2 = 0.9, 0.99
        c1, c2 = 1.0 - b1**self.t, 1.0 - b2**self.t
        for p, g, m, v in zip(self.params, grads, self.m, self.v):
            m *= b1
            m += (1.0 - b1) * g
            v *= b2
            v += (1.0 - b2) * (g * g)
            p -= (self.lr * scale / c1) * m / (np.sqrt(v / c2) + 1e-12)


def _step(ws: list[np.ndarray], bs: list[np.ndarray], z: np.ndarray, phi: np.ndarray, m: np.ndarray,
          y: np.ndarray, wk: np.ndarray) -> tuple[float, np.ndarray, list[np.ndarray], list[np.ndarray]]:
    """Loss and gradients of one batch: codes ``z (bt, L)`` x samples ``phi (bs, F)``, ``m``/``y`` ``(bt, bs, C)``.

    The first layer is split into the code's part (per texel) and the
    features' part (per sample), added by broadcasting: the batch's
    ``bt x bs`` first-layer products cost ``bt + bs`` rows.
    """
    nl = z.shape[1]
    bt, bsz = z.shape[0], phi.shape[0]
    w0 = ws[0]
    pre = [(z @ w0[:nl])[:, None, :] + (phi @ w0[nl:] + bs[0])[None]]
    acts = [np.maximum(pre[0], 0.0).reshape(bt * bsz, -1)]
    for w, b in zip(ws[1:-1], bs[1:-1]):
        pre.append(acts[-1] @ w + b)
        acts.append(np.maximum(pre[-1], 0.0))
    o = (acts[-1] @ ws[-1] + bs[-1]).reshape(bt, bsz, -1)
    r = m * (1.0 + o) - y
    wr = r * wk
    loss = float(np.sum(wr * r))
    g = (2.0 * wr * m).reshape(bt * bsz, -1)
    gw, gb = [np.empty(0, np.float32)] * len(ws), [np.empty(0, np.float32)] * len(bs)
    for i in range(len(ws) - 1, 0, -1):
        gw[i] = acts[i - 1].T @ g
        gb[i] = g.sum(axis=0)
        g = (g @ ws[i].T) * (pre[i - 1].reshape(bt * bsz, -1) > 0)
    g = g.reshape(bt, bsz, -1)
    gz_pre, gf_pre = g.sum(axis=1), g.sum(axis=0)
    gw[0] = np.concatenate([z.T @ gz_pre, phi.T @ gf_pre], axis=0)
    gb[0] = gf_pre.sum(axis=0)
    return loss, gz_pre @ w0[:nl].T, gw, gb


def _positions(rng: np.random.Generator, shape: tuple[int, int], n: int,
               between: float) -> tuple[NDArray[np.int64], NDArray[np.float32]]:
    """``n`` positions on a level of ``shape (n_v, n_u)``: its four nearest texels and their bilinear weights.

    A fraction ``1 - between`` are texel centres (distinct, one texel with
    weight 1); the others uniform over the repeat, so that the decoder also
    learns the codes blended between centres (what a lookup there decodes)
    against the texels blended the same way.
    """
    nv, nu = shape
    t = nv * nu
    n_at = n - int(round(between * n))
    centre = rng.choice(t, size=min(n_at, t), replace=False)
    idx = np.repeat(centre[:, None], 4, axis=1)
    w = np.zeros((centre.size, 4), np.float32)
    w[:, 0] = 1.0
    k = n - centre.size
    if k > 0:
        x, y = rng.uniform(0, nu, k) - 0.5, rng.uniform(0, nv, k) - 0.5
        i0, j0 = np.floor(x).astype(np.int64), np.floor(y).astype(np.int64)
        tu, tv = (x - i0).astype(np.float32), (y - j0).astype(np.float32)
        i0, j0 = i0 % nu, j0 % nv
        i1, j1 = (i0 + 1) % nu, (j0 + 1) % nv
        idx = np.concatenate([idx, np.stack([j0 * nu + i0, j0 * nu + i1, j1 * nu + i0, j1 * nu + i1], 1)])
        w = np.concatenate([w, np.stack([(1 - tu) * (1 - tv), tu * (1 - tv), (1 - tu) * tv, tu * tv], 1)])
    return idx, w


def fit(y: NDArray[np.float32], phi: NDArray[np.float32], mean: NDArray[np.float32], kappa_index: NDArray[np.int64],
        constants: tuple[float, float, float], options: FitOptions | None = None) -> Neural:
    """Fit codes and decoder to texels ``y (n_v, n_u, S, C)`` at samples with features ``phi (S, F)``.

    ``mean (S, C)``: the tile mean at the samples; ``kappa_index (S,)``: each
    sample's curvature slice (the loss weighs every slice by its energy, as the
    recorded per-curvature errors do).
    """
    options = FitOptions() if options is None else options
    rng = np.random.default_rng(options.seed)
    nv, nu, s, c = y.shape
    shapes = level_shapes(nu, nv)
    targets = [y.reshape(nv * nu, s, c).astype(np.float32)]
    targets += [block_means(y, sh).reshape(sh[0] * sh[1], s, c) for sh in shapes[1:]]
    nk = int(kappa_index.max()) + 1
    energy = np.array([np.sum(targets[0][:, kappa_index == k].astype(np.float64) ** 2) for k in range(nk)])
    per_sample = (1.0 / np.maximum(energy, 1e-30))[kappa_index] * (nk * nv * nu)  # sum over all = ~1
    codes = [_init_codes(rng, targets[0], options.latent_dims)]
    for sh in shapes[1:]:
        codes.append(block_means(codes[0].reshape(nv, nu, -1), sh).reshape(sh[0] * sh[1], -1))
    ws, bs = _init_layers(rng, [options.latent_dims + phi.shape[1], *options.hidden, c])
    params = codes + ws + bs
    adam = _Adam(params, options.learning_rate)
    nlev = len(shapes)
    t0 = time.perf_counter()
    rows = min(options.texels_per_batch, nv * nu) * min(options.samples_per_batch, s)
    steps = int(min(options.steps, max(100, math.ceil(options.epochs * nv * nu * s / rows))))
    for it in range(steps):
        lev = 0 if nlev == 1 or rng.random() >= options.coarse_fraction else int(rng.integers(1, nlev))
        tgt = targets[lev]
        si = rng.choice(s, size=min(options.samples_per_batch, s), replace=False)
        idx, wts = _positions(rng, shapes[lev], min(options.texels_per_batch, tgt.shape[0]), options.between)
        z = np.einsum("bk,bkl->bl", wts, codes[lev][idx])
        y = np.einsum("bk,bksc->bsc", wts, tgt[idx[:, :, None], si[None, None, :]])
        m = mean[si][None]
        wk = per_sample[si][None, :, None].astype(np.float32) / (idx.shape[0] * si.size)
        loss, gz, gw, gb = _step(ws, bs, z, phi[si], m, y, wk)
        grads = [np.zeros_like(c) for c in codes] + gw + gb
        np.add.at(grads[lev], idx.reshape(-1), (wts[:, :, None] * gz[:, None, :]).reshape(-1, gz.shape[1]))
        adam.step(grads, 0.5 * (1.0 + math.cos(math.pi * it / steps)))
        if it % 200 == 0:
            _LOG.debug("neural fit: step %d, batch relative RMS %.4f (%.1f s)", it, math.sqrt(loss / nk),
                       time.perf_counter() - t0)
    lat = tuple(z.reshape(sh + (-1,)).astype(np.float16).astype(np.float32) for z, sh in zip(codes, shapes))
    return Neural(lat, tuple(ws), tuple(bs), constants)


def relative_errors(y: NDArray[np.floating], pred: NDArray[np.floating],
                    kappa_index: NDArray[np.int64], n_kappa: int) -> tuple[float, NDArray[np.float64]]:
    """Relative RMS error of ``pred`` against ``y`` (both ``(T, S, C)``): overall and per curvature slice."""
    num, den = np.zeros(n_kappa), np.zeros(n_kappa)
    for k in range(n_kappa):
        sel = kappa_index == k
        if not sel.any():
            continue
        a = y[:, sel].astype(np.float64)
        num[k] = float(np.sum((pred[:, sel] - a) ** 2))
        den[k] = float(np.sum(a**2))
    per = np.sqrt(num / np.where(den > 0, den, 1.0))
    return float(math.sqrt(num.sum() / (den.sum() or 1.0))), per


def level_weights(footprint_texels: NDArray[np.floating],
                  n_levels: int) -> tuple[NDArray[np.int64], NDArray[np.float64], NDArray[np.float64]]:
    """The pyramid level of a footprint (in level-0 texels): ``(level, t, fade)``.

    ``lambda = max(0, log2(footprint))``; the codes of levels ``level`` and
    ``level + 1`` are blended with weight ``t`` of the coarser; beyond the
    last level (``lambda >= n_levels - 1``) the modulation fades to zero over
    one level: ``fade`` is the factor of the modulation (1 up close, 0 from
    ``lambda = n_levels`` on, where the CD-BTF is its tile mean).
    """
    f = np.asarray(footprint_texels, np.float64)
    with np.errstate(divide="ignore", invalid="ignore"):
        lam = np.where(np.isfinite(f) & (f > 1.0), np.log2(np.where(f > 1.0, f, 1.0)), 0.0)
    top = n_levels - 1
    lev = np.minimum(np.floor(lam), top).astype(np.int64)
    t = np.where(lev < top, lam - lev, 0.0)
    fade = np.clip(n_levels - lam, 0.0, 1.0)
    return lev, t, fade


def bilinear_codes(codes: NDArray[np.float32], fu: NDArray[np.float64], fv: NDArray[np.float64]) -> NDArray[np.float64]:
    """Codes ``(n_v, n_u, L)`` at fractional positions in the repeat (``fu, fv`` in [0, 1)), periodic bilinear
    between texel centres."""
    nv, nu = codes.shape[:2]
    x, y = fu * nu - 0.5, fv * nv - 0.5
    i0, j0 = np.floor(x), np.floor(y)
    tu, tv = (x - i0)[..., None], (y - j0)[..., None]
    i0, j0 = i0.astype(np.int64) % nu, j0.astype(np.int64) % nv
    i1, j1 = (i0 + 1) % nu, (j0 + 1) % nv
    c = codes.astype(np.float64)
    return (c[j0, i0] * (1 - tu) + c[j0, i1] * tu) * (1 - tv) + (c[j1, i0] * (1 - tu) + c[j1, i1] * tu) * tv


def codes_at(net: Neural, fu: NDArray[np.float64], fv: NDArray[np.float64],
             footprint_texels: NDArray[np.floating] | float = 0.0) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The blended code and the modulation's fade at positions ``(fu, fv)`` (fractions of the repeat)."""
    fp = np.broadcast_to(np.asarray(footprint_texels, np.float64), fu.shape)
    lev, t, fade = level_weights(fp, len(net.latents))
    out = np.zeros(fu.shape + (net.latent_dims,))
    for level in np.unique(lev):
        sel = lev == level
        a = bilinear_codes(net.latents[level], fu[sel], fv[sel])
        if level + 1 < len(net.latents):
            b = bilinear_codes(net.latents[level + 1], fu[sel], fv[sel])
            a = a + t[sel][:, None] * (b - a)
        out[sel] = a
    return out, fade


def check(net: Neural, *, texels: tuple[int, int], n_channels: int) -> None:
    """Raise :class:`~cdbrdf.errors.TableError` unless ``net`` fits ``texels`` (n_u, n_v) and ``n_channels``."""
    from ..errors import TableError

    nu, nv = texels
    shapes = level_shapes(nu, nv)
    got = [tuple(int(x) for x in z.shape[:2]) for z in net.latents]
    if got != shapes or any(z.ndim != 3 or z.shape[2] != net.latents[0].shape[2] for z in net.latents):
        raise TableError(f"neural: latent levels {[z.shape for z in net.latents]} do not match {nu} x {nv} texels "
                         f"(levels {shapes})")
    if net.latent_dims < 1 or len(net.weights) < 1 or len(net.weights) != len(net.biases):
        raise TableError("neural: expected at least one latent dimension and one layer with a bias each")
    sizes = net.layers
    if sizes[0] != net.latent_dims + N_FEATURES or sizes[-1] != n_channels:
        raise TableError(f"neural: layers {sizes} do not take {net.latent_dims} + {N_FEATURES} inputs to "
                         f"{n_channels} channels")
    for w, b in zip(net.weights, net.biases):
        if w.ndim != 2 or b.shape != (w.shape[1],):
            raise TableError(f"neural: a layer of shape {w.shape} has a bias of shape {b.shape}")
    for w, b in zip(net.weights[1:], net.weights[:-1]):
        if w.shape[0] != b.shape[1]:
            raise TableError(f"neural: layers {sizes} do not chain")
    arrays = list(net.latents) + list(net.weights) + list(net.biases)
    if not all(np.all(np.isfinite(a)) for a in arrays) or not np.all(np.isfinite(net.constants)):
        raise TableError("neural: contains NaN or infinite values")
    if len(net.constants) != 3 or net.constants[0] <= 0 or net.constants[1] <= 0:
        raise TableError(f"neural: feature constants {net.constants} are not (kappa scale > 0, epsilon > 0, offset)")


def modulation_bound(net: Neural, kappa_axis: NDArray[np.floating], mean_values: NDArray[np.floating]) -> float:
    """An upper bound of ``|o|`` (:meth:`Neural.modulation`) over every code of the pyramid and every query.

    Interval arithmetic in float64: each input's largest magnitude (the codes' per dimension, since bilinear and
    level blends are convex; ``l``, ``v``, ``h`` at most 1; ``kappa / kappa_scale`` on the clamped axis; the log
    luminance of a tile mean in ``[0, max |M|]``) through ``|W|`` and ``|b|`` (ReLU never grows a magnitude).
    ``inf`` when it overflows.
    """
    ks, eps, off = net.constants
    with np.errstate(all="ignore"):
        z = np.max(np.stack([np.max(np.abs(np.asarray(a, np.float64)).reshape(-1, a.shape[-1]), axis=0)
                             for a in net.latents]), axis=0)
        mmax = float(np.max(np.abs(np.asarray(mean_values, np.float64)))) if np.size(mean_values) else 0.0
        lum = max(abs(math.log(eps) - off), abs(math.log(mmax + eps) - off))
        kmax = float(np.max(np.abs(np.asarray(kappa_axis, np.float64)))) / ks
        x = np.concatenate([z, np.ones(9), [kmax, lum]])
        for w, b in zip(net.weights, net.biases):
            x = np.abs(np.asarray(w, np.float64)).T @ x + np.abs(np.asarray(b, np.float64))
        top = float(np.max(x))
    return top if math.isfinite(top) else math.inf


def decoded_bound(mean_values: NDArray[np.floating], weights: NDArray[np.floating], basis: NDArray[np.floating],
                  net: Neural | None, kappa_axis: NDArray[np.floating]) -> float:
    """An upper bound of the magnitude of a CD-BTF's value at any position, footprint and query.

    ``max |M| (1 + max |o|)`` for a neural part (``max |M|`` without), plus ``sum_i max |w_i| max |basis_i|``
    of the components (bilinear weights, level blends and the lookup rule are convex combinations). float64;
    ``inf`` when it overflows.
    """
    with np.errstate(all="ignore"):
        m = float(np.max(np.abs(np.asarray(mean_values, np.float64)))) if np.size(mean_values) else 0.0
        r = int(weights.shape[-1])
        comps = 0.0
        if r:
            wmax = np.max(np.abs(np.asarray(weights, np.float64).reshape(-1, r)), axis=0)
            bmax = np.max(np.abs(np.moveaxis(np.asarray(basis, np.float64), -2, 0).reshape(r, -1)), axis=1)
            comps = float(np.sum(wmax * bmax))
        total = m * (1.0 + modulation_bound(net, kappa_axis, mean_values)) + comps if net is not None else m + comps
    return total if math.isfinite(total) else math.inf


def clamp_query(grid: Grid, theta_v: NDArray[np.float64], phi_v: NDArray[np.float64], theta_l: NDArray[np.float64],
                phi_l: NDArray[np.float64], kappa: NDArray[np.float64]
                ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.float64],
                           NDArray[np.float64]]:
    """The query as the lookup rule sees it: elevations and kappa clamped to the axes, an isotropic table's
    azimuths rotated to light azimuth 0."""
    tv = np.clip(theta_v, grid.theta_v[0], grid.theta_v[-1])
    tl = np.clip(theta_l, grid.theta_l[0], grid.theta_l[-1])
    k = np.clip(kappa, grid.kappa[0], grid.kappa[-1])
    if grid.isotropic:
        return tv, np.mod(phi_v - phi_l, 360.0), tl, np.zeros_like(phi_l), k
    return tv, phi_v, tl, phi_l, k


def neural_at(net: Neural, grid: Grid, fu: NDArray[np.float64], fv: NDArray[np.float64],
              footprint_texels: NDArray[np.float64], query: list[NDArray[np.float64]],
              mean_rgb: NDArray[np.float64]) -> NDArray[np.float64]:
    """``max(0, M (1 + fade o))`` at positions (fractions of the repeat), footprints, queries (degrees, mm^-1) and
    the tile mean there."""
    z, fade = codes_at(net, fu, fv, footprint_texels)
    tv, pv, tl, pl, k = clamp_query(grid, *query)
    phi = features(tv, pv, tl, pl, k, mean_rgb, net.constants)
    with np.errstate(invalid="ignore"):
        return np.maximum(mean_rgb * (1.0 + fade[:, None] * net.modulation(z, phi)), 0.0)


def grid_features(grid: Grid, mean: NDArray[np.floating], constants: tuple[float, float, float]
                  ) -> tuple[NDArray[np.float32], NDArray[np.int64]]:
    """The features of every grid sample (kappa-major, as the table's flat order) and each one's kappa index."""
    idx = np.unravel_index(np.arange(int(np.prod(grid.shape))), grid.shape)
    ki, pli, tli, pvi, tvi = idx
    phi = features(np.asarray(grid.theta_v)[tvi], np.asarray(grid.phi_v)[pvi], np.asarray(grid.theta_l)[tli],
                   np.asarray(grid.phi_l)[pli], np.asarray(grid.kappa)[ki],
                   np.asarray(mean).reshape(-1, mean.shape[-1]), constants)
    return phi, ki.astype(np.int64)


def decode_codes(net: Neural, z: NDArray[np.floating], phi: NDArray[np.float32], mean: NDArray[np.floating]
                 ) -> NDArray[np.float32]:
    """``max(0, M (1 + o))`` for every code ``z (T, L)`` at every sample ``phi (S, F)``, ``mean (S, C)``.

    Returns ``(T, S, C)`` float32.
    """
    t, nl = z.shape
    s = phi.shape[0]
    w0 = net.weights[0]
    a = np.asarray(z, np.float32) @ w0[:nl]
    b = phi @ w0[nl:] + net.biases[0]
    m = np.asarray(mean, np.float32)
    out = np.empty((t, s, m.shape[-1]), np.float32)
    step = max(1, (1 << 19) // max(s, 1))
    for t0 in range(0, t, step):
        x = np.maximum(a[t0 : t0 + step, None, :] + b[None], 0.0).reshape(-1, b.shape[1])
        for i, (w, bias) in enumerate(zip(net.weights[1:], net.biases[1:])):
            x = x @ w + bias
            if i < len(net.weights) - 2:
                np.maximum(x, 0.0, out=x)
        out[t0 : t0 + step] = np.maximum(m * (1.0 + x.reshape(-1, s, m.shape[-1])), 0.0)
    return out


def decode_grid(net: Neural, grid: Grid, mean: NDArray[np.floating]) -> NDArray[np.float32]:
    """The neural part at the texel centres (level 0) and every grid sample: ``(n_v * n_u, samples, C)``."""
    phi, _ = grid_features(grid, mean, net.constants)
    z = net.latents[0].reshape(-1, net.latent_dims)
    return decode_codes(net, z, phi, np.asarray(mean).reshape(-1, mean.shape[-1]))


class Residual(NamedTuple):
    """Components added to the neural part: ``weights (T, r)``, ``basis (r, samples * C)``."""

    weights: NDArray[np.float32]
    basis: NDArray[np.float32]


def compress(values: NDArray[np.floating], grid: Grid, *, max_error: float, max_rank: int,
             options: FitOptions | None = None) -> tuple[NDArray[np.float32], Neural, Residual, dict[str, Any]]:
    """Texels ``(n_v, n_u) + grid.shape + (C,)`` -> tile mean (float16 values), neural part, residual components,
    the compression record.

    The residual components (a principal component analysis of what the
    decoder leaves, its mean the first component) are added only when the
    neural part misses ``max_error`` overall or in a curvature slice, as many
    as the target needs (at most ``max_rank``).
    """
    from ._factor import factorise

    opts = FitOptions() if options is None else options
    nv, nu = values.shape[:2]
    c = values.shape[-1]
    s = int(np.prod(grid.shape))
    y = np.asarray(values, np.float32).reshape(nv, nu, s, c)
    m = y.reshape(nv * nu, s, c).mean(axis=0, dtype=np.float64)
    m16 = m.astype(np.float16).astype(np.float32) if np.max(np.abs(m)) < 6e4 else m.astype(np.float32)
    const = feature_constants(np.asarray(grid.kappa), m16)
    phi, ki = grid_features(grid, m16, const)
    t0 = time.perf_counter()
    net = fit(y, phi, m16, ki, const, opts)
    seconds = time.perf_counter() - t0
    flat = y.reshape(nv * nu, s, c)
    pred = decode_codes(net, net.latents[0].reshape(nv * nu, -1), phi, m16)
    nk = grid.shape[0]
    err, err_k = relative_errors(flat, pred, ki, nk)
    comp: dict[str, Any] = {"method": "neural", "max_error": float(max_error), "neural_relative_rms_error": err,
                            "fit_seconds": round(seconds, 1)}
    rank = 0
    weights, basis = np.zeros((nv * nu, 0), np.float32), np.zeros((0, s * c), np.float32)
    if err > max_error + 1e-9 or np.any(err_k > max_error + 1e-9):
        energy = np.array([float(np.sum(flat[:, ki == k].astype(np.float64) ** 2)) for k in range(nk)])
        res = (flat - pred).reshape(nv * nu, s * c)
        f = factorise(res, nk, max_error=max_error, max_rank=max(0, max_rank - 1), energy_per_kappa=energy)
        weights = np.concatenate([np.ones((nv * nu, 1), np.float32), f.weights], axis=1)
        basis = np.concatenate([f.mean[None].astype(np.float32), f.basis], axis=0)
        err, err_k = f.error, f.error_per_kappa
        rank = weights.shape[1]
    comp.update({"rank": rank, "relative_rms_error": float(err),
                 "relative_rms_error_per_kappa": [float(e) for e in err_k]})
    _LOG.info("neural CD-BTF: %d x %d texels, %d latent dimensions, layers %s, fitted in %.1f s: relative RMS "
              "error %.4f (neural part %.4f), %d residual components", nu, nv, net.latent_dims, net.layers, seconds,
              err, comp["neural_relative_rms_error"], rank)
    return m16.reshape(grid.shape + (c,)), net, Residual(weights, basis), comp
