"""Exact pulse-to-mode synthesis (PHYSICS.md section 6).

A force ``F(t)`` at ``x0`` drives each mode ``k`` of the plate (pole
``p_k = -sigma_k + i omega_dk``, shape ``phi_k``, modal mass ``M_k``)::

    q_k'' + 2 sigma_k q_k' + omega_k^2 q_k = b_k F(t),       b_k = phi_k(x0) / M_k

After a pulse that starts at ``t_n`` the mode rings exactly as

    q_k(t) = Re[A_nk exp(p_k (t - t_n))],    A_nk = -i b_k L_nk / omega_dk,
    L_nk = Int_0^tau F(u) exp(-p_k u) du         (the pulse's Laplace transform at the pole)

and a listener hears ``Re[G_k p_k A_nk exp(...)]`` (velocity times the
microphone's Rayleigh gain ``G_k``, Pa per m/s) or ``Re[phi_k(xp) p_k^2 A_nk
exp(...)]`` (an accelerometer, m/s^2). Samples inside a contact get the exact
partial transform ``Int_0^(t - t_n)`` instead, plus, for acceleration, the
direct term ``b_k F(t)``. Every impact is a complex amplitude injected into one
pass of the modal bank, so overlapping tails add exactly and every onset sits at
its true (sub-sample) time: nothing is rounded to the sample grid. A mode at or
above the Nyquist frequency is never rendered, so nothing aliases.

The transform is computed with the trapezoid rule on a uniform grid of the
pulse (from the contact solver's dense output). The pulse vanishes at both ends
like ``u^(3/2)``, so the rule's error is ``|zeta(-3/2)| (h/tau)^(5/2)`` of the
impulse (Navot's endpoint expansion; 8e-7 for 64 points), and the grid is made
fine enough that ``omega_max h <= pi/2``, so the exponential is resolved at
every mode's frequency.

Leaving out (each bounded by ``floor``, a fraction of ``reference``, the sum of
the amplitudes ``|C_nk|`` of the loudest impact, which bounds the output's peak):

* a mode whose amplitude is below ``floor * reference / n_modes`` for every
  impact is not rendered;
* a mode's tail stops when its amplitude falls below that same threshold (checked
  every block of samples) and restarts at the next impact.

So the omitted modes and tails add up to at most ``floor * reference`` at any
sample.
"""

from __future__ import annotations

import math
import time

import numba
import numpy as np

#: Samples per block of the modal bank (the tail floor is checked once a block).
BLOCK = 256


# fast-math without approximate transcendental functions ("afn"): exp, cos, sin stay exact
_FAST = {"nnan", "ninf", "nsz", "arcp", "contract", "reassoc"}


@numba.njit(cache=True, fastmath=_FAST)
def _impact(pr, pi, cr, ci, h, forces, offsets, offset_forces, weight, tau, shift, amps, resp):
    """One impact's contribution (vectorised over the K modes).

    pr, pi: poles (real, imaginary parts); cr, ci: listener response per unit transform
    (``-i b_k output_k / omega_dk``); h, forces: the pulse on a uniform grid u_j = j h;
    offsets (M,), offset_forces (M,): times inside the contact (s from first touch) of the
    audio samples there (equally spaced, one sample apart), and the force at them; weight: the weight m g (N) left on the plate
    after a settled contact (0 otherwise); shift: time from first touch to the injection
    sample (s). Writes amps (K,) complex: the ringing at the injection sample; resp (M,):
    the exact response at the in-contact samples (partial transforms).
    """
    K = pr.shape[0]
    N = forces.shape[0]
    M = offsets.shape[0]
    er = np.ones(K)
    ei = np.zeros(K)
    sr = np.empty(K)
    si = np.empty(K)
    ar = np.zeros(K)
    ai = np.zeros(K)
    for k in range(K):
        mag = math.exp(-pr[k] * h)
        sr[k] = mag * math.cos(-pi[k] * h)
        si[k] = mag * math.sin(-pi[k] * h)
    # e^(+p d) at the in-contact samples, advanced sample by sample (d_(m+1) = d_m + 1/fs)
    gr = np.empty(K)
    gi = np.empty(K)
    rr = np.empty(K)
    ri = np.empty(K)
    if M > 0:
        d0 = offsets[0]
        dt = (offsets[M - 1] - d0) / (M - 1) if M > 1 else 0.0
        for k in range(K):
            mag = math.exp(pr[k] * d0)
            gr[k] = mag * math.cos(pi[k] * d0)
            gi[k] = mag * math.sin(pi[k] * d0)
            mag = math.exp(pr[k] * dt)
            rr[k] = mag * math.cos(pi[k] * dt)
            ri[k] = mag * math.sin(pi[k] * dt)
    m = 0
    half = 0.5 * h
    f_prev = forces[0]
    for j in range(N):
        fj = forces[j]
        if j > 0:
            # acc += h/2 (F_(j-1) E_(j-1) + F_j E_j), with E_(j-1) = E_j / step
            for k in range(K):
                # E_j = E_(j-1) * step
                nr = er[k] * sr[k] - ei[k] * si[k]
                ni = er[k] * si[k] + ei[k] * sr[k]
                ar[k] += half * (f_prev * er[k] + fj * nr)
                ai[k] += half * (f_prev * ei[k] + fj * ni)
                er[k] = nr
                ei[k] = ni
        uj = j * h
        while m < M and (j == N - 1 or offsets[m] < uj + h):
            d = offsets[m]
            dd = d - uj
            if dd < 0.0:
                dd = 0.0
            fd = offset_forces[m]
            acc = 0.0
            for k in range(K):
                # e^(-p d) = conj(e^(p d)) / |e^(p d)|^2
                g2 = gr[k] * gr[k] + gi[k] * gi[k]
                tr = gr[k] / g2
                ti = -gi[k] / g2
                qr = ar[k] + 0.5 * dd * (fj * er[k] + fd * tr)
                qi = ai[k] + 0.5 * dd * (fj * ei[k] + fd * ti)
                # Re[c * q * e^(p d)]
                xr = qr * gr[k] - qi * gi[k]
                xi = qr * gi[k] + qi * gr[k]
                acc += cr[k] * xr - ci[k] * xi
                # advance e^(p d) to the next sample
                nr = gr[k] * rr[k] - gi[k] * ri[k]
                gi[k] = gr[k] * ri[k] + gi[k] * rr[k]
                gr[k] = nr
            resp[m] = acc
            m += 1
        f_prev = fj
    for k in range(K):
        zr = ar[k]
        zi = ai[k]
        if weight != 0.0:
            # the weight left on the plate: + m g e^(-p tau) / p
            mag = math.exp(-pr[k] * tau)
            wr = mag * math.cos(-pi[k] * tau)
            wi = mag * math.sin(-pi[k] * tau)
            den = pr[k] * pr[k] + pi[k] * pi[k]
            zr += weight * (wr * pr[k] + wi * pi[k]) / den
            zi += weight * (wi * pr[k] - wr * pi[k]) / den
        # times c, times e^(p shift)
        xr = zr * cr[k] - zi * ci[k]
        xi = zr * ci[k] + zi * cr[k]
        mag = math.exp(pr[k] * shift)
        gr = mag * math.cos(pi[k] * shift)
        gi = mag * math.sin(pi[k] * shift)
        amps[k] = complex(xr * gr - xi * gi, xr * gi + xi * gr)


@numba.njit(cache=True, fastmath=_FAST)
def _bank(out, fs, poles, amps, inject, thresholds, block):
    """The modal bank, mode by mode.

    out (S,) float64 accumulates; poles (K,) complex; amps (I, K) complex amplitudes of the
    impacts' ringing, already referred to the injection samples inject (I,) int64 (ascending):
    the mode's state at sample inject[i] gains amps[i, k]. thresholds (K,): a mode whose
    amplitude falls below its threshold stops until the next injection.
    Returns the number of mode-samples computed and the end of the last one written (the
    samples after it are exactly zero).
    """
    S = out.shape[0]
    K = poles.shape[0]
    I = inject.shape[0]
    pr = np.empty(block + 1)
    pi = np.empty(block + 1)
    work = 0
    last = 0
    for k in range(K):
        p = poles[k]
        # r^j for j = 0..block: by recurrence, re-anchored on an exact exponential every
        # 32 steps (rounding stays below ~32 ulp; 1/32 of the exponentials)
        r1 = np.exp(p / fs)
        for j in range(block + 1):
            if j % 32 == 0:
                z = np.exp(p * (j / fs))
            else:
                z = z * r1
            pr[j] = z.real
            pi[j] = z.imag
        thr2 = thresholds[k] * thresholds[k]
        zr = 0.0
        zi = 0.0
        active = False
        s = 0
        for i in range(I + 1):
            stop = inject[i] if i < I else S
            if stop > S:
                stop = S
            # propagate the current state from s to stop
            if active:
                b = s
                while b < stop:
                    n = min(block, stop - b)
                    for j in range(n):
                        out[b + j] += zr * pr[j] - zi * pi[j]
                    work += n
                    if b + n > last:
                        last = b + n
                    # advance the state by n samples
                    if n == block:
                        cr = pr[block]
                        ci = pi[block]
                    else:
                        w = np.exp(p * (n / fs))
                        cr = w.real
                        ci = w.imag
                    zr, zi = zr * cr - zi * ci, zr * ci + zi * cr
                    b += n
                    if zr * zr + zi * zi < thr2:
                        active = False
                        zr = 0.0
                        zi = 0.0
                        break
            if i == I or inject[i] >= S:
                break
            s = inject[i]
            zr += amps[i, k].real
            zi += amps[i, k].imag
            active = zr * zr + zi * zi >= thr2
    return work, last


def pulse_grid(result, omega_max, min_points=64):
    """Uniform grid of a pulse fine enough for the transform: ``(h, forces)``.

    ``omega_max`` (rad/s) is the highest mode's angular frequency; the grid has at least
    ``min_points`` points and a step ``h`` with ``omega_max h <= pi / 2``.
    """
    tau = result.contact_time
    n = max(min_points, int(math.ceil(2.0 * omega_max * tau / math.pi)) + 1)
    h = tau / (n - 1)
    u = np.arange(n) * h
    f = result.force_at(u)
    return h, np.ascontiguousarray(f)


def synthesize(impacts, onsets, poles, excitation, output, samplerate, *, floor, settled_weight=None,
               direct=None, max_samples=None):
    """Mix the ringing of every mode after every impact.

    Parameters
    ----------
    impacts : sequence of ImpactResult
        The contacts, in time order.
    onsets : ndarray (I,)
        Each contact's start on the audio timeline, s (float, sub-sample).
    poles : complex ndarray (K,)
        ``p_k = -sigma_k + i omega_dk``, rad/s (all below Nyquist).
    excitation : ndarray (K,)
        ``b_k = phi_k(x0) / M_k``, 1/kg.
    output : complex ndarray (K,)
        Listener gain per unit modal displacement ``q_k`` at the pole: ``phi_k(xp) p_k^2``
        for acceleration, ``G_k p_k`` for a microphone.
    samplerate : float
        Hz.
    floor : float
        Omission floor, a fraction of the reference amplitude (see module docstring).
    settled_weight : sequence of float or None
        For a settled impact, the weight ``m g`` (N) that stays on the plate after its
        contact time (its step adds ``m g exp(-p tau) / p`` to the transform); else None.
    direct : ndarray (K,) or None
        For acceleration, ``phi_k(xp) b_k`` of the direct term ``b_k F(t)`` inside contacts.
    max_samples : int
        Length cap of the output.

    Returns
    -------
    (audio float64 (S,), info dict: n_modes_rendered, mode_samples, reference, length)
    """
    fs = float(samplerate)
    poles = np.ascontiguousarray(poles, dtype=complex)
    K = poles.size
    omega_max = float(np.max(np.abs(poles.imag))) if K else 0.0
    wd = poles.imag
    I = len(impacts)
    amps = np.zeros((I, K), dtype=complex)
    inject = np.zeros(I, dtype=np.int64)
    contact_samples = []  # per impact: in-contact sample indices, responses there, forces there
    coef = -1j * excitation / wd * output            # response per unit transform
    pr = np.ascontiguousarray(poles.real)
    pim = np.ascontiguousarray(poles.imag)
    cr = np.ascontiguousarray(coef.real)
    ci = np.ascontiguousarray(coef.imag)
    for i, (res, t0) in enumerate(zip(impacts, onsets)):
        h, forces = pulse_grid(res, omega_max)
        tau = res.contact_time
        first = int(math.ceil(t0 * fs - 1e-9))
        end = int(math.ceil((t0 + tau) * fs - 1e-9))
        idx = np.arange(max(first, 0), max(end, 0), dtype=np.int64)
        offsets = np.ascontiguousarray(idx / fs - t0)   # one sample apart; the kernel guards d < 0
        off_f = np.ascontiguousarray(res.force_at(offsets)) if idx.size else np.zeros(0)
        weight = float(settled_weight[i]) if settled_weight is not None else 0.0
        resp = np.empty(idx.size)
        _impact(pr, pim, cr, ci, h, forces, offsets, off_f, weight, tau, end / fs - t0, amps[i], resp)
        inject[i] = end
        contact_samples.append((idx, resp, off_f))
    reference = float(np.max(np.sum(np.abs(amps), axis=1))) if I else 0.0
    thr = floor * reference / max(K, 1)
    keep = np.max(np.abs(amps), axis=0) >= thr if I else np.zeros(K, bool)
    # buffer: until the last kept tail can fall below the threshold (the sum of a mode's
    # amplitudes bounds its state after the last impact); trimmed below to what was written
    if I and keep.any():
        sig = -poles.real[keep]
        amax = np.sum(np.abs(amps[:, keep]), axis=0)
        t_tail = np.log(np.maximum(amax / max(thr, 1e-300), 1.0)) / np.maximum(sig, 1e-12)
        length = int(inject[-1] + math.ceil(float(np.max(t_tail)) * fs) + BLOCK)
    else:
        length = int(inject[-1] + 1) if I else 1
    if max_samples is not None:
        length = min(length, int(max_samples))
    out = np.zeros(length)
    t_bank = time.perf_counter()
    work, last = _bank(out, fs, poles[keep], np.ascontiguousarray(amps[:, keep]), inject,
                       np.full(int(keep.sum()), thr), BLOCK) if keep.any() else (0, 0)
    t_bank = time.perf_counter() - t_bank
    mass_line = float(np.sum(direct.real)) if direct is not None else 0.0
    for (idx, resp, off_f) in contact_samples:
        ok = idx < length
        if not ok.any():
            continue
        out[idx[ok]] += resp[ok]
        if direct is not None:
            out[idx[ok]] += off_f[ok] * mass_line
        last = max(last, int(idx[ok][-1]) + 1)
    length = max(1, min(length, last))
    out = out[:length]
    info = dict(n_modes=K, n_modes_rendered=int(keep.sum()), mode_samples=int(work),
                reference=reference, threshold=thr, length=length, bank_seconds=t_bank)
    return out, info
