"""Compiled kernels: the bilinear height field, its surface points, their
visibility along directions, and the reflectance integral over the
micro-surface. Private.

The surface is the bilinear interpolation of the texel-centre heights (in
texel coordinates, see ``weave.x_of_xi``); everything here (the points'
positions and normals, the marching of visibility rays) uses that one
surface, so that what is seen, what is lit and how it is shaded agree.

Each kernel handles items ``start`` to ``stop`` (rows, points, directions or
pairs) and releases the GIL; :func:`cdbrdf._jit.run_split` runs ranges in
threads. Every per-item sum runs sequentially within its item, so the results
do not depend on the number of threads.
"""

from __future__ import annotations

import math

from .._jit import njit
from .fibre import P_B, P_G, P_INK, P_R, _terms

__all__: list[str] = []

_MAX_STEPS = 200000
#: Sub-samples per side of a cell when its area is integrated.
_AREA_SUB = 4


@njit(cache=True, inline="always", error_model="numpy")
def _segment(x, xmap):
    """(texel coordinate, d xi / dx) of position x (see ``weave.x_of_xi``)."""
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
        rate = (n1 - n0) / (x1 - x0)
        return c * m + n0 + (u - x0) * rate, rate
    return c * m + n0, 0.0


@njit(cache=True, inline="always", error_model="numpy")
def _cell(fx, fy, nx, ny):
    """The periodic bilinear cell of ``(fx, fy)`` (texel-centre coordinates): corner indices and weights."""
    x0 = math.floor(fx)
    y0 = math.floor(fy)
    i0 = int(x0) % nx
    j0 = int(y0) % ny
    return i0, (i0 + 1) % nx, j0, (j0 + 1) % ny, fx - x0, fy - y0


@njit(cache=True, inline="always", error_model="numpy")
def _height(H, x, y, xmap, dy):
    """Bilinear, periodic interpolation of texel-centre heights."""
    ny, nx = H.shape
    fx = _segment(x, xmap)[0] - 0.5
    fy = y / dy - 0.5
    i0, i1, j0, j1, tx, ty = _cell(fx, fy, nx, ny)
    a = H[j0, i0] * (1.0 - tx) + H[j0, i1] * tx
    b = H[j1, i0] * (1.0 - tx) + H[j1, i1] * tx
    return a * (1.0 - ty) + b * ty


@njit(cache=True, inline="always", error_model="numpy")
def _surface(H, xi, y, dy, rate):
    """Height and gradient (dz/dx, dz/dy) of the bilinear surface at texel coordinate ``xi``.

    ``rate`` is d xi / dx where the point lies.
    """
    ny, nx = H.shape
    fx = xi - 0.5
    fy = y / dy - 0.5
    i0, i1, j0, j1, tx, ty = _cell(fx, fy, nx, ny)
    h00 = H[j0, i0]
    h01 = H[j0, i1]
    h10 = H[j1, i0]
    h11 = H[j1, i1]
    z = (h00 * (1.0 - tx) + h01 * tx) * (1.0 - ty) + (h10 * (1.0 - tx) + h11 * tx) * ty
    gx = ((h01 - h00) * (1.0 - ty) + (h11 - h10) * ty) * rate
    gy = ((h10 - h00) * (1.0 - tx) + (h11 - h01) * tx) / dy
    return z, gx, gy


@njit(cache=True, nogil=True, error_model="numpy")
def cell_areas(H, xedges, dy, out, start, stop):
    """Surface area (mm^2) of the bilinear cells of rows ``start`` to ``stop``.

    Cell ``(j, i)`` spans the texel centres ``(j, i)`` to ``(j + 1, i + 1)``,
    i.e. texel coordinates ``[i + 0.5, i + 1.5) x [j + 0.5, j + 1.5)``;
    ``xedges[k]``, ``k = 0..nx``, is the x of texel coordinate ``k`` (texel
    coordinate to x is linear between integers). Midpoint rule on ``_AREA_SUB^2`` sub-cells.
    """
    ny, nx = H.shape
    n = _AREA_SUB
    for j in range(start, stop):
        for i in range(nx):
            acc = 0.0
            for a in range(n):
                xi = i + 0.5 + (a + 0.5) / n
                k = int(math.floor(xi)) % nx
                width = xedges[k + 1] - xedges[k]
                rate = 1.0 / width if width > 0.0 else 0.0
                for b in range(n):
                    y = (j + 0.5 + (b + 0.5) / n) * dy
                    _, gx, gy = _surface(H, xi, y, dy, rate)
                    acc += math.sqrt(1.0 + gx * gx + gy * gy) * width
            out[j, i] = acc * dy / (n * n)


@njit(cache=True, nogil=True, error_model="numpy")
def place_points(H, xedges, dy, xi, yy, tangent, kind, pos, normal, tan_out, kind_out, jac, start, stop):
    """Position, normal, fibre direction, kind and area element of surface points.

    Point ``p`` lies at texel coordinate ``xi[p]`` in ``[0, nx)`` and
    ``y = yy[p]`` (mm).
    Writes ``pos (n, 3)`` (x, y, z in mm), ``normal (n, 3)`` (the bilinear
    surface's unit normal there), ``tan_out (n, 3)`` (the fibre direction of
    the texel it lies in, projected into the surface's tangent plane),
    ``kind_out (n,)`` and ``jac (n,)``: surface area per unit of texel
    coordinate x per mm of y (``sqrt(1 + |grad z|^2) dx / d xi``).
    """
    ny, nx = H.shape
    for p in range(start, stop):
        u = xi[p]
        k = int(math.floor(u)) % nx
        width = xedges[k + 1] - xedges[k]
        rate = 1.0 / width if width > 0.0 else 0.0
        x = xedges[k] + (u - k) * width
        y = yy[p]
        z, gx, gy = _surface(H, u, y, dy, rate)
        s = math.sqrt(1.0 + gx * gx + gy * gy)
        nx_, ny_, nz_ = -gx / s, -gy / s, 1.0 / s
        t = (int(math.floor(y / dy)) % ny) * nx + (k % nx)
        tx, ty, tz = tangent[t, 0], tangent[t, 1], tangent[t, 2]
        d = tx * nx_ + ty * ny_ + tz * nz_
        tx -= d * nx_
        ty -= d * ny_
        tz -= d * nz_
        tn = math.sqrt(tx * tx + ty * ty + tz * tz)
        if tn < 1e-9:  # fibre along the normal: any direction in the surface
            tx, ty, tz = nz_, 0.0, -nx_
            tn = math.sqrt(tx * tx + tz * tz)
        pos[p, 0] = x
        pos[p, 1] = y
        pos[p, 2] = z
        normal[p, 0] = nx_
        normal[p, 1] = ny_
        normal[p, 2] = nz_
        tan_out[p, 0] = tx / tn
        tan_out[p, 1] = ty / tn
        tan_out[p, 2] = tz / tn
        kind_out[p] = kind[t]
        jac[p] = s * width


@njit(cache=True, nogil=True, error_model="numpy")
def visibility(H, xmap, dy, step, pos, normal, dirs, out, start, stop):
    """Write ``out (n_dirs, n_points)`` uint8 for directions ``start`` to ``stop``:
    1 where the point sees along the direction (it faces it and a ray from it
    leaves the cloth without passing under the surface), else 0.

    The ray is tested every ``step`` mm along its length until it rises above
    the highest point of the surface.
    """
    zmax = H.max() + 1e-9
    npt = pos.shape[0]
    for d in range(start, stop):
        dx, dyr, dz = dirs[d, 0], dirs[d, 1], dirs[d, 2]
        if dz <= 0.0:
            continue
        for p in range(npt):
            if normal[p, 0] * dx + normal[p, 1] * dyr + normal[p, 2] * dz <= 0.0:
                continue
            x0, y0, z0 = pos[p, 0], pos[p, 1], pos[p, 2]
            lit = 1
            t = 0.0
            for _ in range(_MAX_STEPS):
                t += step
                z = z0 + t * dz
                if z >= zmax:
                    break
                if z < _height(H, x0 + t * dx, y0 + t * dyr, xmap, dy):
                    lit = 0
                    break
            out[d, p] = lit


@njit(cache=True, nogil=True, error_model="numpy")
def integrate(pair_v, pair_l, dirs, vis, pos, normal, tangent, kind, weight, params, texel_grid, out, start, stop):
    """``sum_p w_p f_p(v, l) (n_p . v) (n_p . l) V_p(v) V_p(l)`` per pair, for pairs ``start`` to ``stop``.

    ``pair_v``/``pair_l`` index ``dirs`` and the rows of ``vis``; ``weight``
    is each point's share of the surface area (mm^2). The sum is symmetric in
    v and l term by term. Writes ``out (n_pairs, n_bins, 3)`` (zeroed): with
    one bin the sum over all points (``pos`` and ``texel_grid`` are not
    read); with more, each point's term goes to the texel where the line
    from the point along ``v`` crosses the height ``texel_grid[0]``, on a
    periodic grid of ``texel_grid[3] x texel_grid[4]`` texels over a repeat
    of ``texel_grid[1] x texel_grid[2]`` mm (bin ``v * n_u + u``).
    """
    npt = normal.shape[0]
    nbin = out.shape[1]
    z_ref = texel_grid[0]
    lx = texel_grid[1]
    ly = texel_grid[2]
    n_u = int(texel_grid[3])
    n_v = int(texel_grid[4])
    for q in range(start, stop):
        iv = pair_v[q]
        il = pair_l[q]
        vx, vy, vz = dirs[iv, 0], dirs[iv, 1], dirs[iv, 2]
        lx_, ly_, lz_ = dirs[il, 0], dirs[il, 1], dirs[il, 2]
        r_acc = 0.0
        g_acc = 0.0
        b_acc = 0.0
        for p in range(npt):
            if vis[iv, p] == 0 or vis[il, p] == 0:
                continue
            nx_, ny_, nz_ = normal[p, 0], normal[p, 1], normal[p, 2]
            cv = nx_ * vx + ny_ * vy + nz_ * vz
            cl = nx_ * lx_ + ny_ * ly_ + nz_ * lz_
            k = kind[p]
            par = params[k]
            s, c = _terms(nx_, ny_, nz_, tangent[p, 0], tangent[p, 1], tangent[p, 2],
                          vx, vy, vz, lx_, ly_, lz_, par)
            w = weight[p] * (cv * cl) * par[P_INK]
            if nbin == 1:
                r_acc += (s + c * par[P_R]) * w
                g_acc += (s + c * par[P_G]) * w
                b_acc += (s + c * par[P_B]) * w
            else:
                # vis[iv, p] != 0 implies vz > 0.
                t = (z_ref - pos[p, 2]) / vz
                fu = (pos[p, 0] + t * vx) / lx
                fv = (pos[p, 1] + t * vy) / ly
                iu = int(math.floor((fu - math.floor(fu)) * n_u)) % n_u
                jv = int(math.floor((fv - math.floor(fv)) * n_v)) % n_v
                b = jv * n_u + iu
                out[q, b, 0] += (s + c * par[P_R]) * w
                out[q, b, 1] += (s + c * par[P_G]) * w
                out[q, b, 2] += (s + c * par[P_B]) * w
        if nbin == 1:
            out[q, 0, 0] = r_acc
            out[q, 0, 1] = g_acc
            out[q, 0, 2] = b_acc
