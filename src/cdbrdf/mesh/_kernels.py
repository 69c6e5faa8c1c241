"""numba loops of the curvature package: face orientation, the per-vertex surface fit, corner normals.

Private: :mod:`cdbrdf.mesh.repair` and :mod:`cdbrdf.mesh.estimate`
wrap them with checked arrays. Compiled on first use (cached on disk where
possible, :mod:`cdbrdf._jit`).
"""

# ruff: noqa: ANN001, ANN201, ANN202 - numba kernels: their arguments and results are numba's types

from __future__ import annotations

import math

import numpy as np

from .._jit import njit

#: Iterations of the fit: a height quadric, then the normal-section model twice.
FIT_ITERATIONS = 3

#: Fewest vertices worth a thread of their own (:func:`cdbrdf._jit.run_split`).
GRAIN = 256

#: A fit is resolved when the fitted surface turns its normal, from the vertex to its samples, by at
#: most this many radians (rms): the samples' normals are within 60 degrees of the vertex's, so a surface
#: through them turns by about 1 radian at most; ill-conditioned fits along a collar's rim or a
#: waistband's ledge (samples nearly on a line) turn by tens.
BEND_MAX = 1.5

#: and when its samples span the neighbourhood in both directions: the smaller second moment of their
#: positions in the tangent plane at least this share of the larger (a curvature across a line of
#: vertices, a crease or a seam line, would be measured at the scale of their jitter).
SPREAD_MIN = 0.05

#: Tukey biweight constant (95 % efficiency under Gaussian noise), in robust standard deviations.
TUKEY_C = 4.685


@njit(cache=True)
def orient_faces(n_faces, ptr, nbr, same):
    """Breadth-first 2-colouring of the face graph: which faces to flip relative to their component's first.

    ``nbr[ptr[f]:ptr[f + 1]]`` are the faces sharing a manifold edge with
    face ``f``; ``same`` is 1 where that neighbour traverses the edge in the
    same direction (one of the two must be flipped). Returns the parity
    (1 = flip), the component of every face, the number of components and
    the number of edges whose constraint contradicts the others (a
    non-orientable surface).
    """
    parity = np.full(n_faces, -1, np.int8)
    comp = np.full(n_faces, -1, np.int64)
    queue = np.empty(n_faces, np.int64)
    n_comp = 0
    conflicts = 0
    for s in range(n_faces):
        if parity[s] >= 0:
            continue
        parity[s] = 0
        comp[s] = n_comp
        head = 0
        tail = 1
        queue[0] = s
        while head < tail:
            f = queue[head]
            head += 1
            for e in range(ptr[f], ptr[f + 1]):
                g = nbr[e]
                want = parity[f] ^ same[e]
                if parity[g] < 0:
                    parity[g] = want
                    comp[g] = n_comp
                    queue[tail] = g
                    tail += 1
                elif parity[g] != want:
                    conflicts += 1
        n_comp += 1
    return parity, comp, n_comp, conflicts // 2


@njit(inline="always")
def _frame(n0, n1, n2):
    """Two unit tangents orthogonal to the unit normal (n0, n1, n2)."""
    if abs(n0) < 0.6:
        ax, ay, az = 1.0, 0.0, 0.0
    elif abs(n1) < 0.6:
        ax, ay, az = 0.0, 1.0, 0.0
    else:
        ax, ay, az = 0.0, 0.0, 1.0
    d = ax * n0 + ay * n1 + az * n2
    t0, t1, t2 = ax - d * n0, ay - d * n1, az - d * n2
    s = math.sqrt(t0 * t0 + t1 * t1 + t2 * t2)
    t0, t1, t2 = t0 / s, t1 / s, t2 / s
    return t0, t1, t2, n1 * t2 - n2 * t1, n2 * t0 - n0 * t2, n0 * t1 - n1 * t0


@njit(inline="always")
def _solve6(m, b, out):
    """Solve the symmetric 6x6 system ``m x = b`` by Gaussian elimination with partial pivoting."""
    a = m.copy()
    r = b.copy()
    for c in range(6):
        p = c
        big = abs(a[c, c])
        for i in range(c + 1, 6):
            if abs(a[i, c]) > big:
                big = abs(a[i, c])
                p = i
        if big < 1e-300:
            return False
        if p != c:
            for j in range(6):
                tmp = a[c, j]
                a[c, j] = a[p, j]
                a[p, j] = tmp
            tmp = r[c]
            r[c] = r[p]
            r[p] = tmp
        for i in range(c + 1, 6):
            f = a[i, c] / a[c, c]
            if f != 0.0:
                for j in range(c, 6):
                    a[i, j] -= f * a[c, j]
                r[i] -= f * r[c]
    for c in range(5, -1, -1):
        s = r[c]
        for j in range(c + 1, 6):
            s -= a[c, j] * out[j]
        out[c] = s / a[c, c]
    return True


@njit(inline="always")
def _median(a, n):
    """The (upper) median of ``a[:n]``, by quickselect; ``a`` is reordered."""
    k = n // 2
    lo = 0
    hi = n - 1
    while lo < hi:
        pivot = a[(lo + hi) // 2]
        i = lo
        j = hi
        while i <= j:
            while a[i] < pivot:
                i += 1
            while a[j] > pivot:
                j -= 1
            if i <= j:
                t = a[i]
                a[i] = a[j]
                a[j] = t
                i += 1
                j -= 1
        if k <= j:
            hi = j
        elif k >= i:
            lo = i
        else:
            break
    return a[k]


@njit(inline="always", error_model="numpy")
def _start(i, q_nrm, k1, k2, d1, d2):
    """Zero query ``i``'s curvatures and directions; whether it has a normal, and the unit normal."""
    n0 = q_nrm[i, 0]
    n1 = q_nrm[i, 1]
    n2 = q_nrm[i, 2]
    ln = math.sqrt(n0 * n0 + n1 * n1 + n2 * n2)
    k1[i] = 0.0
    k2[i] = 0.0
    for c in range(3):
        d1[i, c] = 0.0
        d2[i, c] = 0.0
    if not ln > 0.0:
        return False, n0, n1, n2
    return True, n0 / ln, n1 / ln, n2 / ln


@njit(inline="always", error_model="numpy")
def _principal(i, ka, kb, kc, t10, t11, t12, t20, t21, t22, k1, k2, d1, d2):
    """The principal curvatures and directions of the tensor ``[[ka, kb], [kb, kc]]`` in the frame (t1, t2)."""
    mean = 0.5 * (ka + kc)
    half = math.sqrt(0.25 * (ka - kc) * (ka - kc) + kb * kb)
    k1[i] = mean + half
    k2[i] = mean - half
    # eigenvector of k1: angle th with tan(2 th) = 2 kb / (ka - kc)
    th = 0.5 * math.atan2(2.0 * kb, ka - kc)
    ct = math.cos(th)
    st = math.sin(th)
    d1[i, 0] = ct * t10 + st * t20
    d1[i, 1] = ct * t11 + st * t21
    d1[i, 2] = ct * t12 + st * t22
    d2[i, 0] = -st * t10 + ct * t20
    d2[i, 1] = -st * t11 + ct * t21
    d2[i, 2] = -st * t12 + ct * t22


@njit(inline="always", error_model="numpy")
def _candidates(i, n0, n1, n2, q_comp, s_nrm, s_comp, nbr, nbr_d, radius, k_min, cos_max, sel):
    """The samples of query ``i``'s fit into ``sel``: how many, and the radius used.

    Normal within the cone, within the radius (or the ``k_min`` nearest);
    where too few normals agree (a mesh coarser than its folds), any normal.
    """
    kk = nbr.shape[1]
    ns = s_nrm.shape[0]
    cnt = 0
    r_use = radius
    for cone in (cos_max, -2.0):
        cnt = 0
        r_use = radius
        for j in range(kk):
            s = nbr[i, j]
            if s >= ns:
                break
            if s_comp[s] != q_comp[i]:
                continue
            if s_nrm[s, 0] * n0 + s_nrm[s, 1] * n1 + s_nrm[s, 2] * n2 < cone:
                continue
            if nbr_d[i, j] <= radius:
                sel[cnt] = s
                cnt += 1
            elif cnt < k_min:
                sel[cnt] = s
                cnt += 1
                r_use = nbr_d[i, j]
            else:
                break
        if cnt >= 6:
            break
    return cnt, r_use


@njit(inline="always", error_model="numpy")
def _weights(it, cnt, wg, w, res, tmp):
    """The fit's weights at iteration ``it``: Tukey's biweight of the previous fit's residuals after the first."""
    if it == 0:
        return
    for j in range(cnt):
        tmp[j] = abs(res[j])
    med = _median(tmp, cnt)
    scale = 1.4826 * med
    if scale > 1e-9:
        cut = TUKEY_C * scale
        for j in range(cnt):
            u = abs(res[j]) / cut
            w[j] = wg[j] * (1.0 - u * u) ** 2 if u < 1.0 else 0.0
    else:
        for j in range(cnt):
            w[j] = wg[j]


@njit(inline="always", error_model="numpy")
def _solve_fit(cnt, x, y, h, g, w, m, b, coef, row):
    """The weighted least squares of the height model in ``coef``; False when it has no solution."""
    m[:, :] = 0.0
    b[:] = 0.0
    wsum = 0.0
    for j in range(cnt):
        if w[j] <= 0.0:
            continue
        wsum += w[j]
        row[0] = 1.0
        row[1] = x[j]
        row[2] = y[j]
        row[3] = 0.5 * x[j] * x[j] * g[j]
        row[4] = x[j] * y[j] * g[j]
        row[5] = 0.5 * y[j] * y[j] * g[j]
        for p in range(6):
            wp = w[j] * row[p]
            b[p] += wp * h[j]
            for q in range(p, 6):
                m[p, q] += wp * row[q]
    for p in range(6):
        for q in range(p):
            m[p, q] = m[q, p]
    tr = 0.0
    for p in range(6):
        tr += m[p, p]
    for p in range(6):
        m[p, p] += 1e-10 * tr + 1e-300
    return wsum > 0.0 and _solve6(m, b, coef)


@njit(inline="always", error_model="numpy")
def _fit_surface(i, cnt, sigma, q_pos, n0, n1, n2, s_pos, s_w, sel, x, y, h, g, wg, w, res, tmp, m, b, coef, row):
    """The iterated fit of :func:`fit_vertices` (see its description): whether it succeeded, the normal and the
    tangent frame it ends in (the curvature tensor is in ``coef[3:]``, the samples in ``x``, ``y``, weights ``w``)."""
    inv_s = 1.0 / sigma
    ox = q_pos[i, 0]
    oy = q_pos[i, 1]
    oz = q_pos[i, 2]
    t10, t11, t12, t20, t21, t22 = _frame(n0, n1, n2)
    coef[:] = 0.0
    for it in range(FIT_ITERATIONS):
        for j in range(cnt):
            s = sel[j]
            dx = (s_pos[s, 0] - ox) * inv_s
            dy = (s_pos[s, 1] - oy) * inv_s
            dz = (s_pos[s, 2] - oz) * inv_s
            x[j] = dx * t10 + dy * t11 + dz * t12
            y[j] = dx * t20 + dy * t21 + dz * t22
            h[j] = dx * n0 + dy * n1 + dz * n2
            rho2 = x[j] * x[j] + y[j] * y[j]
            dd = rho2 + h[j] * h[j]
            g[j] = dd / rho2 if (it > 0 and rho2 > 1e-12) else 1.0
            if it == 0:
                wg[j] = s_w[s] * math.exp(-0.5 * dd)
                w[j] = wg[j]
        _weights(it, cnt, wg, w, res, tmp)
        if not _solve_fit(cnt, x, y, h, g, w, m, b, coef, row):
            return False, n0, n1, n2, t10, t11, t12, t20, t21, t22
        for j in range(cnt):
            res[j] = h[j] - (coef[0] + coef[1] * x[j] + coef[2] * y[j] + 0.5 * coef[3] * x[j] * x[j] * g[j]
                             + coef[4] * x[j] * y[j] * g[j] + 0.5 * coef[5] * y[j] * y[j] * g[j])
        if it < FIT_ITERATIONS - 1:
            # move the origin onto the fitted surface, tilt the normal by the gradient
            ox += coef[0] * sigma * n0
            oy += coef[0] * sigma * n1
            oz += coef[0] * sigma * n2
            a0 = n0 - coef[1] * t10 - coef[2] * t20
            a1 = n1 - coef[1] * t11 - coef[2] * t21
            a2 = n2 - coef[1] * t12 - coef[2] * t22
            la = math.sqrt(a0 * a0 + a1 * a1 + a2 * a2)
            n0, n1, n2 = a0 / la, a1 / la, a2 / la
            # keep t1 as close as possible to the previous one
            dt = t10 * n0 + t11 * n1 + t12 * n2
            u0, u1, u2 = t10 - dt * n0, t11 - dt * n1, t12 - dt * n2
            lu = math.sqrt(u0 * u0 + u1 * u1 + u2 * u2)
            if lu < 1e-6:
                t10, t11, t12, t20, t21, t22 = _frame(n0, n1, n2)
            else:
                t10, t11, t12 = u0 / lu, u1 / lu, u2 / lu
                t20, t21, t22 = n1 * t12 - n2 * t11, n2 * t10 - n0 * t12, n0 * t11 - n1 * t10
    return True, n0, n1, n2, t10, t11, t12, t20, t21, t22


@njit(inline="always", error_model="numpy")
def _resolved(cnt, ka, kb, kc, sigma, x, y, w):
    """Whether a fit is resolved (:data:`BEND_MAX`, :data:`SPREAD_MIN`).

    The fitted surface turns its normal, between the vertex and its samples,
    by at most BEND_MAX radians (rms): their normals are within the cone of
    the vertex's, so a fit that turns by more shows what they do not (a
    spike, along a rim or a ledge where they are nearly collinear); and the
    samples span the neighbourhood across as well as along (not a line of vertices).
    """
    turn = 0.0
    ws = 0.0
    sxx = 0.0
    sxy = 0.0
    syy = 0.0
    for j in range(cnt):
        if w[j] > 0.0:
            sx = (ka * x[j] + kb * y[j]) * sigma
            sy = (kb * x[j] + kc * y[j]) * sigma
            turn += w[j] * (sx * sx + sy * sy)
            ws += w[j]
            sxx += w[j] * x[j] * x[j]
            sxy += w[j] * x[j] * y[j]
            syy += w[j] * y[j] * y[j]
    disc = math.sqrt(0.25 * (sxx - syy) * (sxx - syy) + sxy * sxy)
    spread = 0.5 * (sxx + syy) - disc >= SPREAD_MIN * (0.5 * (sxx + syy) + disc)
    return ws > 0.0 and turn <= BEND_MAX * BEND_MAX * ws and spread


@njit(cache=True, error_model="numpy")
def _fit_one(i, q_pos, q_nrm, q_comp, s_pos, s_nrm, s_w, s_comp, nbr, nbr_d, radius, k_min, cos_max,
             k1, k2, d1, d2, nrm, status, sel, x, y, h, g, wg, w, res, tmp, m, b, coef, row):
    """The fit of :func:`fit_vertices` at query ``i``, in the caller's scratch arrays."""
    has_normal, n0, n1, n2 = _start(i, q_nrm, k1, k2, d1, d2)
    for c in range(3):
        nrm[i, c] = 0.0
    if not has_normal:
        status[i] = 2
        return
    nrm[i, 0], nrm[i, 1], nrm[i, 2] = n0, n1, n2
    cnt, r_use = _candidates(i, n0, n1, n2, q_comp, s_nrm, s_comp, nbr, nbr_d, radius, k_min, cos_max, sel)
    if cnt < 6:
        status[i] = 1
        return
    sigma = 0.5 * r_use
    inv_s = 1.0 / sigma
    ok, n0, n1, n2, t10, t11, t12, t20, t21, t22 = _fit_surface(i, cnt, sigma, q_pos, n0, n1, n2, s_pos, s_w, sel,
                                                                 x, y, h, g, wg, w, res, tmp, m, b, coef, row)
    if not ok:
        status[i] = 1
        return
    # curvature tensor in the last frame: kappa > 0 where the surface bends away from the normal
    ka = -coef[3] * inv_s
    kb = -coef[4] * inv_s
    kc = -coef[5] * inv_s
    resolved = _resolved(cnt, ka, kb, kc, sigma, x, y, w)
    _principal(i, ka, kb, kc, t10, t11, t12, t20, t21, t22, k1, k2, d1, d2)
    nrm[i, 0], nrm[i, 1], nrm[i, 2] = n0, n1, n2
    status[i] = 0 if resolved else 3


@njit(cache=True, nogil=True, error_model="numpy")
def fit_vertices(
    q_pos, q_nrm, q_comp, s_pos, s_nrm, s_w, s_comp, nbr, nbr_d, radius, k_min, cos_max,
    k1, k2, d1, d2, nrm, status, start, stop,
):
    """Fit the surface around the query vertices ``start`` to ``stop``; write principal curvatures and directions.

    For query ``i`` the candidates are its k nearest samples (``nbr[i]``,
    sorted by distance ``nbr_d[i]``) of the same connected component whose
    normal is within ``acos(cos_max)`` of the query's; those within ``radius`` are used, or
    the ``k_min`` nearest when fewer lie within it. Weights: the sample's
    own (cluster size) times a Gaussian of sigma = half the radius used.

    The fit, in the frame of the normal: first the height quadric
    ``h = f + a x + b y + (A x^2 + 2 B x y + C y^2) / 2``, which moves the
    origin onto the surface (``f``) and tilts the normal (``a, b``); then
    twice the normal-section model, in which the second-order term is
    scaled by ``|d|^2 / (x^2 + y^2)``: a sample at distance ``d`` on the
    circle of curvature ``k`` tangent at the origin has ``2 h = k |d|^2``
    exactly, so a sphere is fitted without bias at any radius and a cylinder
    nearly so (the plain quadric overestimates a cylinder of radius R by
    about 6 % over a neighbourhood of radius 0.66 R). The last two fits are
    reweighted with Tukey's biweight of the previous residuals (robust scale:
    1.4826 x the median absolute residual), which removes outliers.

    Where fewer than 6 candidates pass the normal test (a mesh coarser than
    its folds), the test is dropped for that vertex.

    ``status``: 0 fitted, 1 too few samples (curvature 0), 2 no normal, 3
    unresolved (the fit turns by more than :data:`BEND_MAX` radians over
    the samples: a spike, no surface they show).
    Releases the GIL: :func:`cdbrdf._jit.run_split` runs ranges in threads.
    """
    kk = nbr.shape[1]
    sel = np.empty(kk, np.int64)
    x = np.empty(kk)
    y = np.empty(kk)
    h = np.empty(kk)
    g = np.empty(kk)
    wg = np.empty(kk)
    w = np.empty(kk)
    res = np.empty(kk)
    tmp = np.empty(kk)
    m = np.empty((6, 6))
    b = np.empty(6)
    coef = np.zeros(6)
    row = np.empty(6)
    for i in range(start, stop):
        _fit_one(i, q_pos, q_nrm, q_comp, s_pos, s_nrm, s_w, s_comp, nbr, nbr_d, radius, k_min, cos_max,
                 k1, k2, d1, d2, nrm, status, sel, x, y, h, g, wg, w, res, tmp, m, b, coef, row)


@njit(cache=True, nogil=True, error_model="numpy")
def transfer_tensors(q_nrm, q_comp, s_nrm, s_comp, s_ok, s_fn, s_k1, s_k2, s_d1, s_d2, nbr, nbr_d, sigma,
                     cos_max, k1, k2, d1, d2, status, start, stop):
    """Curvature at vertices ``start`` to ``stop`` from the fits at nearby samples (a mesh much finer
    than the neighbourhood).

    The shape operators ``k1 d1 d1^T + k2 d2 d2^T`` of the query's nearest
    fitted samples (same component, normal within the cone) are averaged with
    Gaussian weights of sigma ``sigma`` (the sample spacing), projected into
    the tangent plane of the samples' mean fitted normal ``s_fn`` (not the
    query's own, which on a noisy scan is tilted by the noise and would
    shrink the curvature by the square of the tilt's cosine) and decomposed
    again. ``status``: 0 done, 1 no
    usable sample.
    """
    kk = nbr.shape[1]
    ns = s_nrm.shape[0]
    inv2 = 0.5 / (sigma * sigma)
    for i in range(start, stop):
        has_normal, n0, n1, n2 = _start(i, q_nrm, k1, k2, d1, d2)
        if not has_normal:
            status[i] = 1
            continue
        s00 = s01 = s02 = s11 = s12 = s22 = 0.0
        m0 = m1 = m2 = 0.0
        wsum = 0.0
        for j in range(kk):
            s = nbr[i, j]
            if s >= ns:
                break
            if not s_ok[s] or s_comp[s] != q_comp[i]:
                continue
            if s_nrm[s, 0] * n0 + s_nrm[s, 1] * n1 + s_nrm[s, 2] * n2 < cos_max:
                continue
            w = math.exp(-nbr_d[i, j] * nbr_d[i, j] * inv2) + 1e-12
            a1, a2 = s_k1[s], s_k2[s]
            e0, e1, e2 = s_d1[s, 0], s_d1[s, 1], s_d1[s, 2]
            f0, f1, f2 = s_d2[s, 0], s_d2[s, 1], s_d2[s, 2]
            s00 += w * (a1 * e0 * e0 + a2 * f0 * f0)
            s01 += w * (a1 * e0 * e1 + a2 * f0 * f1)
            s02 += w * (a1 * e0 * e2 + a2 * f0 * f2)
            s11 += w * (a1 * e1 * e1 + a2 * f1 * f1)
            s12 += w * (a1 * e1 * e2 + a2 * f1 * f2)
            s22 += w * (a1 * e2 * e2 + a2 * f2 * f2)
            m0 += w * s_fn[s, 0]
            m1 += w * s_fn[s, 1]
            m2 += w * s_fn[s, 2]
            wsum += w
        lm = math.sqrt(m0 * m0 + m1 * m1 + m2 * m2)
        if wsum <= 0.0 or not lm > 0.0:
            status[i] = 1
            continue
        n0, n1, n2 = m0 / lm, m1 / lm, m2 / lm
        t10, t11, t12, t20, t21, t22 = _frame(n0, n1, n2)
        # the 2x2 tensor in the query's tangent frame: t^T S t
        st0 = s00 * t10 + s01 * t11 + s02 * t12
        st1 = s01 * t10 + s11 * t11 + s12 * t12
        st2 = s02 * t10 + s12 * t11 + s22 * t12
        ka = (st0 * t10 + st1 * t11 + st2 * t12) / wsum
        kb = (st0 * t20 + st1 * t21 + st2 * t22) / wsum
        su0 = s00 * t20 + s01 * t21 + s02 * t22
        su1 = s01 * t20 + s11 * t21 + s12 * t22
        su2 = s02 * t20 + s12 * t21 + s22 * t22
        kc = (su0 * t20 + su1 * t21 + su2 * t22) / wsum
        _principal(i, ka, kb, kc, t10, t11, t12, t20, t21, t22, k1, k2, d1, d2)
        status[i] = 0

