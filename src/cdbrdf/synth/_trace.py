"""Compiled kernels: ray marching over a periodic height field and the
reflectance integral over the visible micro-surface. Private.

Each kernel handles items ``start`` to ``stop`` (views, lights or pairs) and
releases the GIL; :func:`cdbrdf._jit.run_split` runs ranges in threads.
Every per-item sum runs sequentially within its item, so the results do not
depend on the number of threads.
"""

from __future__ import annotations

import math

from .._jit import njit
from .fibre import P_B, P_G, P_INK, P_R, _terms

__all__: list[str] = []

_MAX_STEPS = 200000


@njit(cache=True, inline="always", error_model="numpy")
def _xi(x, xmap):
    """Texel coordinate along x of position x (see ``weave.x_of_xi``)."""
    pitch = xmap[0]
    m = xmap[8]
    c = math.floor(x / pitch)
    u = x - c * pitch
    if u < xmap[2]:
        k = 0
    elif u < xmap[3]:
        k = 1
    else:
        k = 2
    x0 = xmap[1 + k]
    x1 = xmap[2 + k]
    n0 = xmap[5 + k]
    n1 = xmap[6 + k]
    if x1 > x0:
        loc = n0 + (u - x0) / (x1 - x0) * (n1 - n0)
    else:
        loc = n0
    return c * m + loc


@njit(cache=True, inline="always", error_model="numpy")
def _height(H, x, y, xmap, dy):
    """Bilinear, periodic interpolation of texel-centre heights."""
    ny, nx = H.shape
    fx = _xi(x, xmap) - 0.5
    fy = y / dy - 0.5
    x0 = math.floor(fx)
    y0 = math.floor(fy)
    tx = fx - x0
    ty = fy - y0
    i0 = int(x0) % nx
    j0 = int(y0) % ny
    i1 = (i0 + 1) % nx
    j1 = (j0 + 1) % ny
    a = H[j0, i0] * (1.0 - tx) + H[j0, i1] * tx
    b = H[j1, i0] * (1.0 - tx) + H[j1, i1] * tx
    return a * (1.0 - ty) + b * ty


@njit(cache=True, inline="always", error_model="numpy")
def _texel(x, y, xmap, dy, nx, ny):
    i = int(math.floor(_xi(x, xmap))) % nx
    j = int(math.floor(y / dy)) % ny
    return j * nx + i


@njit(cache=True, nogil=True, error_model="numpy")
def trace_views(H, xmap, dy, step, views, points, out, start, stop):
    """Texel hit first by each view ray, for views ``start`` to ``stop``.

    Rays start on the plane just above the highest point, at ``points (N, 2)``
    (spread uniformly over the repeat), and travel along ``-v``. Writes
    ``out (n_views, N)``: int64 flat texel indices.
    """
    ny, nx = H.shape
    zmax = H.max() + 1e-6
    zmin = H.min()
    npt = points.shape[0]
    for iv in range(start, stop):
        vx, vy, vz = views[iv, 0], views[iv, 1], views[iv, 2]
        tmax = (zmax - zmin) / max(vz, 1e-9) + step
        for r in range(npt):
            x0, y0 = points[r, 0], points[r, 1]
            t_prev = 0.0
            t = 0.0
            hit = False
            for _ in range(_MAX_STEPS):
                t = min(t + step, tmax)
                z = zmax - t * vz
                if z <= _height(H, x0 - t * vx, y0 - t * vy, xmap, dy):
                    hit = True
                    break
                if t >= tmax:
                    break
                t_prev = t
            if hit:
                lo, hi = t_prev, t
                for _ in range(12):
                    mid = 0.5 * (lo + hi)
                    if zmax - mid * vz <= _height(H, x0 - mid * vx, y0 - mid * vy, xmap, dy):
                        hi = mid
                    else:
                        lo = mid
                t = hi
            out[iv, r] = _texel(x0 - t * vx, y0 - t * vy, xmap, dy, nx, ny)


@njit(cache=True, inline="always", error_model="numpy")
def _lit(H, xs, xmap, dy, zmax, step, j, i, lx, ly, lz):
    """1 if the texel centre (j, i) on the surface sees direction l, else 0."""
    x0 = xs[i]
    y0 = (j + 0.5) * dy
    z0 = H[j, i] + 0.05 * step
    t = 0.0
    for _ in range(_MAX_STEPS):
        t += step
        z = z0 + t * lz
        if z >= zmax:
            return 1
        if z < _height(H, x0 + t * lx, y0 + t * ly, xmap, dy):
            return 0
    return 1


@njit(cache=True, nogil=True, error_model="numpy")
def shadow_maps(H, xs, xmap, dy, step, lights, needed, out, start, stop):
    """Write ``out (n_lights, ny * nx)`` uint8 (zeroed), for lights ``start`` to ``stop``: 1 where a texel
    centre sees the light.

    ``xs``: texel centres along x. Only texels with ``needed[flat] != 0`` are
    traced (others are left 0).
    """
    ny, nx = H.shape
    zmax = H.max() + 1e-6
    for il in range(start, stop):
        lx, ly, lz = lights[il, 0], lights[il, 1], lights[il, 2]
        if lz <= 0.0:
            continue
        for k in range(ny * nx):
            if needed[k] == 0:
                continue
            j = k // nx
            i = k - j * nx
            out[il, k] = _lit(H, xs, xmap, dy, zmax, step, j, i, lx, ly, lz)


@njit(cache=True, nogil=True, error_model="numpy")
def integrate(pair_v, pair_l, views, lights, hits, shadow, shadow_row, normal, tangent, kind, params, bins, out,
              start, stop):
    """Mean over the view rays of ``f_p(v, l) (n_p . l)+ V(p, l)`` per pair, for pairs ``start`` to ``stop``.

    ``pair_v``/``pair_l`` index ``views``/``lights``; ``shadow_row[l]`` is the
    row of ``shadow`` for light ``l``. Writes ``out (n_pairs, n_bins, 3)``:
    with one bin, the mean over all rays (``bins`` is not read); with more,
    the rays of view ``v`` are summed into bin ``bins[v, r]`` (the texel the
    ray belongs to) and scaled by ``n_bins / n_rays`` (the mean of a bin when
    every bin holds as many rays; the mean over the bins is the mean over the rays).
    """
    npt = hits.shape[1]
    nbin = out.shape[1]
    scale = nbin / npt
    for q in range(start, stop):
        iv = pair_v[q]
        il = pair_l[q]
        vx, vy, vz = views[iv, 0], views[iv, 1], views[iv, 2]
        lx, ly, lz = lights[il, 0], lights[il, 1], lights[il, 2]
        srow = shadow_row[il]
        r_acc = 0.0
        g_acc = 0.0
        b_acc = 0.0
        for r in range(npt):
            k = hits[iv, r]
            if shadow[srow, k] == 0:
                continue
            nx_, ny_, nz_ = normal[k, 0], normal[k, 1], normal[k, 2]
            cl = nx_ * lx + ny_ * ly + nz_ * lz
            if cl <= 0.0:
                continue
            cv = nx_ * vx + ny_ * vy + nz_ * vz
            if cv <= 0.0:
                continue
            p = params[kind[k]]
            s, c = _terms(nx_, ny_, nz_, tangent[k, 0], tangent[k, 1], tangent[k, 2],
                          vx, vy, vz, lx, ly, lz, p)
            w = cl * p[P_INK]
            if nbin == 1:
                r_acc += (s + c * p[P_R]) * w
                g_acc += (s + c * p[P_G]) * w
                b_acc += (s + c * p[P_B]) * w
            else:
                b = bins[iv, r]
                out[q, b, 0] += (s + c * p[P_R]) * w * scale
                out[q, b, 1] += (s + c * p[P_G]) * w * scale
                out[q, b, 2] += (s + c * p[P_B]) * w * scale
        if nbin == 1:
            out[q, 0, 0] = r_acc / npt
            out[q, 0, 1] = g_acc / npt
            out[q, 0, 2] = b_acc / npt
