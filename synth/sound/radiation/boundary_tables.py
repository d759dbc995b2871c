"""The boundary rule's tables (numba kernels): the radial solutions ``F`` and their
derivatives on the grid by cumulative integrals, oscillating and decaying, and the edge
integrals of each row of modes.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from synth.compilation import compiled
from synth.physics.asymptotic_modes import edge_part, interior_part
from synth.sound.radiation.boundary_bessel import A0, A1, ASYMPTOTIC_X, bessel_at, small_bessel
from synth.sound.radiation.boundary_grid import DECAY_LADDER, DECAY_MIN_C, SENTINEL, decay_weights
from synth.sound.radiation.common import MAX_ORDER


@compiled()
def _cumulate(sflat, off, vals, out):  # pragma: no cover
    """``out[a] = sum_b S[a, b] vals[b]``: cumulative integrals inside one panel."""
    p = vals.size
    for a in range(p):
        acc = 0.0j
        row = off + a * p
        for b in range(p):
            acc += sflat[row + b] * vals[b]
        out[a] = acc


@compiled()
def _parts(x, s, so, h, n, ce, scale, interior, edge):  # pragma: no cover
    """Interior and edge parts ``(u, e)`` of a trial factor (normalised, see
    :func:`synth.physics.asymptotic_modes.factor_parts`) at ``x`` in ``[-h, h]``; a part
    not asked for (``interior``, ``edge`` False) is 0."""
    u = scale * interior_part(x, s, h, n) if interior else 0.0
    e = scale * ce * edge_part(x, s, so, h, n) if edge else 0.0
    return u, e


@compiled()
def _slopes(x, s, so, h, n, ce, scale):  # pragma: no cover
    """Derivatives ``(u', e')`` (per unit of ``x``) of the parts of :func:`_parts`."""
    odd = n % 2 == 1
    m2 = s + 2.0 * so
    if s > 0.0:
        k = math.sqrt(s)
        du = math.cos(k * x) if odd else -k * math.sin(k * x)
    elif s < 0.0:
        k = math.sqrt(-s)
        du = math.cosh(k * x) if odd else k * math.sinh(k * x)
    else:
        du = 1.0 if odd else 0.0
    if m2 > 0.0:
        mu = math.sqrt(m2)
        d1 = math.exp(-mu * (h - x))
        d2 = math.exp(-mu * (h + x))
        den = 1.0 + math.exp(-2.0 * mu * h) * (-1.0 if odd else 1.0)
        if odd:
            de = mu * (d1 + d2) / den if den > 0.0 else 1.0 / h
        else:
            de = mu * (d1 - d2) / den
    elif m2 < 0.0:
        mu = math.sqrt(-m2)
        if odd:
            de = mu * math.cos(mu * x) / math.sin(mu * h)
        else:
            de = -mu * math.sin(mu * x) / math.cos(mu * h)
    else:
        de = 1.0 / h if odd else 0.0
    return scale * du, scale * ce * de


@compiled()
def _decaying_tables(
    kap, f0, g0, g, rho, starts, lo, hi, on_edge, etab, eoff, ekap, va, vb, oa, ob, ca, cb
):  # pragma: no cover
    """The radial integrals of a decaying row (``q^2 = -kap^2``) at the nodes of the
    panels ``on_edge``: ``ca = Int_0^rho exp(-kap (rho - t)) i0e(kap t) G t dt`` and
    ``cb = Int_rho^R1 exp(-kap (t - rho)) k0e(kap t) G t dt`` (``f0 = i0e``, ``g0 = k0e``,
    ``g = G t`` times the Jacobian). Panel ``i`` takes the product weights ``etab[eoff[i]
    :]`` (:func:`decay_weights`, ``(p + 1) x p``) of the rate ``ekap[i] <= kap`` (1/m)
    and carries ``exp((kap - ekap[i]) (t - lo))`` in its values (``ekap[i] = 0``: the
    whole exponential, on a short or substituted panel)."""
    n_panels = lo.size
    last = -1
    for i in range(n_panels):
        if on_edge[i]:
            last = i
    # forward, to the last panel with boundary nodes
    base = 0.0j
    for i in range(last + 1):
        s0 = starts[i]
        p = starts[i + 1] - s0
        rest = kap - ekap[i]
        off = eoff[i]
        for a in range(p):
            j = s0 + a
            va[a] = f0[j] * g[j] * math.exp(rest * (rho[j] - lo[i]))
        tot = 0.0j
        row = off + p * p
        for b in range(p):
            tot += etab[row + b] * va[b]
        if on_edge[i]:
            _cumulate(etab, off, va[:p], oa)
            for a in range(p):
                j = s0 + a
                ca[j] = base * math.exp(-kap * (rho[j] - lo[i]))
                ca[j] += oa[a] * math.exp(-rest * (rho[j] - lo[i]))
        base = base * math.exp(-kap * (hi[i] - lo[i])) + tot * math.exp(-rest * (hi[i] - lo[i]))
    # backward from the tail's end: mirrored weights (the nodes are symmetric)
    base = 0.0j
    for i in range(n_panels - 1, -1, -1):
        s0 = starts[i]
        p = starts[i + 1] - s0
        rest = kap - ekap[i]
        off = eoff[i]
        for a in range(p):
            j = s0 + p - 1 - a  # mirrored order
            vb[a] = g0[j] * g[j] * math.exp(rest * (hi[i] - rho[j]))
        tot = 0.0j
        row = off + p * p
        for b in range(p):
            tot += etab[row + b] * vb[b]
        if on_edge[i]:
            _cumulate(etab, off, vb[:p], ob)
            for a in range(p):
                j = s0 + p - 1 - a
                cb[j] = base * math.exp(-kap * (hi[i] - rho[j]))
                cb[j] += ob[a] * math.exp(-rest * (hi[i] - rho[j]))
        base = base * math.exp(-kap * (hi[i] - lo[i])) + tot * math.exp(-rest * (hi[i] - lo[i]))


@compiled()
def _row_tables(
    g,
    rho,
    gw,
    starts,
    lo,
    hi,
    on_edge,
    sflat,
    soff,
    etab,
    eoff,
    ekap,
    q2,
    small_x,
    small_at,
    small,
    a0,
    a1,
    f,
    df,
):  # pragma: no cover
    """``F`` and ``F'`` (module notes) of one row's Helmholtz part ``q2`` (1/m^2) into
    ``f``, ``df`` at the nodes of the panels ``on_edge`` (the others are left untouched:
    only their totals enter); ``g = G t`` times the Jacobian at the nodes. Bessel values
    from the Hankel expansions, below ``small_x`` from ``small`` (rows ``f0, g0, f1,
    g1``, this row's from ``small_at``); for a decaying part the product weights of each
    panel (:func:`_decaying_tables`)."""
    n = rho.size
    n_panels = lo.size
    p_max = 0
    last = -1
    for i in range(n_panels):
        p_max = max(p_max, starts[i + 1] - starts[i])
        if on_edge[i]:
            last = i
    f0 = np.empty(n)
    g0 = np.empty(n)
    ca = np.empty(n, dtype=np.complex128)
    cb = np.empty(n, dtype=np.complex128)
    va = np.empty(p_max, dtype=np.complex128)
    vb = np.empty(p_max, dtype=np.complex128)
    oa = np.empty(p_max, dtype=np.complex128)
    ob = np.empty(p_max, dtype=np.complex128)
    osc = q2 > 0.0
    kap = math.sqrt(abs(q2))
    # an oscillating part's integrals run forward only: to the last boundary node
    n_used = starts[last + 1] if osc else n
    for j in range(n_used):
        x = kap * rho[j]
        if x < small_x:
            f0[j] = small[0, small_at + j]
            g0[j] = small[1, small_at + j]
        else:
            f0[j], g0[j] = bessel_at(x, osc, a0, 0.25 * math.pi)
    if osc:
        # (pi / 2) [Y0 Int_0^rho J0 G t dt - J0 Int_0^rho Y0 G t dt]
        base_a = 0.0j
        base_b = 0.0j
        for i in range(last + 1):
            s0, s1 = starts[i], starts[i + 1]
            p = s1 - s0
            tot_a = 0.0j
            tot_b = 0.0j
            for a in range(p):
                j = s0 + a
                va[a] = f0[j] * g[j]
                vb[a] = g0[j] * g[j]
                tot_a += gw[j] * va[a]
                tot_b += gw[j] * vb[a]
            if on_edge[i]:
                _cumulate(sflat, soff[i], va[:p], oa)
                _cumulate(sflat, soff[i], vb[:p], ob)
                for a in range(p):
                    ca[s0 + a] = base_a + oa[a]
                    cb[s0 + a] = base_b + ob[a]
            base_a += tot_a
            base_b += tot_b
    else:
        _decaying_tables(
            kap, f0, g0, g, rho, starts, lo, hi, on_edge, etab, eoff, ekap, va, vb, oa, ob, ca, cb
        )
    for i in range(last + 1):
        if not on_edge[i]:
            continue
        for j in range(starts[i], starts[i + 1]):
            x = kap * rho[j]
            if x < small_x:
                f1 = small[2, small_at + j]
                g1 = small[3, small_at + j]
            else:
                f1, g1 = bessel_at(x, osc, a1, 0.75 * math.pi)
            if osc:
                f[j] = 0.5 * math.pi * (g0[j] * ca[j] - f0[j] * cb[j])
                df[j] = 0.5 * math.pi * kap * (-g1 * ca[j] + f1 * cb[j])
            else:
                f[j] = -(f0[j] * cb[j] + g0[j] * ca[j])
                df[j] = -kap * (f1 * cb[j] - g1 * ca[j])


@compiled(parallel=True)
def _row_integrals(
    rho,
    rbig,
    jac,
    gw,
    starts,
    lo,
    hi,
    on_edge,
    sflat,
    soff,
    etab,
    eoff,
    ekap,
    q2,
    sigma,
    r0,
    small_x,
    small_starts,
    small,
    a0,
    a1,
    edge_axis,
    edge_high,
    edge_d,
    edge_start,
    edge_idx,
    edge_pos,
    edge_w,
    sx,
    sy,
    nx,
    ny,
    hx,
    hy,
    cx,
    gx,
    cy,
    gy,
    big,
    a,
    b,
    out,
):  # pragma: no cover
    """``out[r] = Oint (psi dF/dn - F dpsi/dn) ds`` summed over the three Helmholtz parts
    of each row's trial product (``part`` 0: interior x interior, 1: interior x edge and
    edge x interior, 2: edge x edge; ``q2[part, r]``), their ``F`` (:func:`_row_tables`)
    at the boundary nodes; the trial's parts at a boundary node evaluated once for the
    three. ``etab``, ``eoff[part]``, ``ekap[part]``, ``small_starts[part]``,
    ``small[part]``: each part's product weights and small-argument Bessel values."""
    m = out.size
    n = rho.size
    for r in numba.prange(m):
        g = np.empty(n, dtype=np.complex128)
        for j in range(n):
            g[j] = np.exp(-sigma[r] * (rbig[j] - r0)) / rbig[j] * rho[j] * jac[j]
        f = np.empty((3, n), dtype=np.complex128)
        df = np.empty((3, n), dtype=np.complex128)
        for part in range(3):
            _row_tables(
                g,
                rho,
                gw,
                starts,
                lo,
                hi,
                on_edge,
                sflat,
                soff,
                etab,
                eoff[part, r],
                ekap[part, r],
                q2[part, r],
                small_x,
                small_starts[part, r],
                small[part],
                a0,
                a1,
                f[part],
                df[part],
            )
        acc = 0.0j
        for e in range(edge_axis.size):
            sign = 1.0 if edge_high[e] else -1.0
            d = edge_d[e]
            if edge_axis[e] == 0:  # x = const, along y
                xe = ((a if edge_high[e] else 0.0) - 0.5 * a) / big
                au, ae = _parts(xe, sx[r], sy[r], hx, nx[r], cx[r], gx[r], True, True)
                du, de = _slopes(xe, sx[r], sy[r], hx, nx[r], cx[r], gx[r])
            else:
                xe = ((b if edge_high[e] else 0.0) - 0.5 * b) / big
                au, ae = _parts(xe, sy[r], sx[r], hy, ny[r], cy[r], gy[r], True, True)
                du, de = _slopes(xe, sy[r], sx[r], hy, ny[r], cy[r], gy[r])
            du *= sign / big
            de *= sign / big
            for jj in range(edge_start[e], edge_start[e + 1]):
                j = edge_idx[jj]
                if edge_axis[e] == 0:
                    t = (edge_pos[jj] - 0.5 * b) / big
                    vu, ve = _parts(t, sy[r], sx[r], hy, ny[r], cy[r], gy[r], True, True)
                else:
                    t = (edge_pos[jj] - 0.5 * a) / big
                    vu, ve = _parts(t, sx[r], sy[r], hx, nx[r], cx[r], gx[r], True, True)
                geo = d / rho[j]
                val = au * vu * df[0, j] * geo - du * vu * f[0, j]
                val += (au * ve + ae * vu) * df[1, j] * geo - (du * ve + de * vu) * f[1, j]
                val += ae * ve * df[2, j] * geo - de * ve * f[2, j]
                acc += edge_w[jj] * val
        out[r] += acc


def _decay_tables(grid, kappa):
    """Product weights of each decay rate ``kappa`` (1/m, any shape; 0 for an oscillating
    row) on each panel of ``grid`` (:func:`_decaying_tables`): the weights of the
    exponent ``c0`` on the ladder ``DECAY_LADDER`` at or below the panel's ``c = kappa h
    / 2`` (``c0 = 0`` below ``DECAY_MIN_C`` and on substituted panels), flattened; the
    offsets into them and the rates ``2 c0 / h`` (shape of ``kappa`` x panels)."""
    h = grid.hi - grid.lo
    c = 0.5 * kappa[..., None] * h
    exact = (c >= DECAY_MIN_C) & (grid.kinds == 0)[None, :]
    with np.errstate(divide="ignore"):
        step = np.where(exact, np.floor(np.log(c) / math.log(DECAY_LADDER)), 0.0).astype(np.int64)
    step -= exact & (DECAY_LADDER ** step.astype(float) > c)  # rounding: c0 <= c
    c0 = np.where(exact, DECAY_LADDER ** step.astype(float), 0.0)
    step = np.where(exact, step + 1 - SENTINEL, 0)  # 0: c0 = 0, else step + 1 - sentinel
    key = step * (4 * MAX_ORDER * MAX_ORDER) + grid.orders  # orders below 4 MAX_ORDER^2
    keys, inverse = np.unique(key.ravel(), return_inverse=True)
    blocks, offsets, at = [], [], 0
    for k in keys:
        p, n = k % (4 * MAX_ORDER * MAX_ORDER), k // (4 * MAX_ORDER * MAX_ORDER)
        rung = DECAY_LADDER ** float(n - 1 + SENTINEL) if n > 0 else 0.0
        blocks.append(decay_weights(int(p), rung).ravel())
        offsets.append(at)
        at += blocks[-1].size
    eoff = np.asarray(offsets, dtype=np.int64)[inverse.ravel()].reshape(c.shape)
    return np.concatenate(blocks), eoff, 2.0 * c0 / h


def entry_integrals(grid, sol, trials, sigma, r0, size, big):
    """``Int X_t Y_t exp(-sigma (R - r0)) / R dA`` for rows ``(trial t, sigma)``: the
    three Helmholtz parts (interior x interior, mixed, edge x edge) on one grid."""
    a, b = size
    hx, hy = sol.half
    (cx, gx), (cy, gy) = sol.factor_constants()
    sx, sy = sol.sx[trials], sol.sy[trials]
    omega = (sx + sy) / (big * big)
    q2 = np.stack((omega, -omega, -3.0 * omega))
    small = [
        small_bessel(np.sqrt(np.abs(q2[part])), grid.rho, part == 0, grid.on_node)
        for part in range(3)
    ]
    width = max(t[1].shape[1] for t in small)
    small_values = np.zeros((3, 4, width))
    for part, (_, values) in enumerate(small):
        small_values[part, :, : values.shape[1]] = values
    small_starts = np.stack([t[0][:-1] for t in small])
    etab, eoff, ekap = _decay_tables(grid, np.sqrt(np.maximum(-q2, 0.0)))
    out = np.zeros(trials.size, dtype=complex)
    _row_integrals(
        grid.rho,
        grid.r_big,
        grid.jac,
        grid.gw,
        grid.starts,
        grid.lo,
        grid.hi,
        grid.on_edge,
        grid.sflat,
        grid.soff,
        etab,
        eoff,
        ekap,
        q2,
        sigma,
        r0,
        ASYMPTOTIC_X,
        small_starts,
        small_values,
        A0,
        A1,
        *grid.edge_arrays,
        sx,
        sy,
        sol.nx[trials],
        sol.ny[trials],
        hx,
        hy,
        cx[trials],
        gx[trials],
        cy[trials],
        gy[trials],
        big,
        a,
        b,
        out,
    )
    return out
