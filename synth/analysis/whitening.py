"""Step 1 (docs/analysis.md, Method): whitening by a linear predictor (Makhoul 1975, Proc. IEEE 63,
561; Stowell and Plumbley 2007, ICMC), and step 7's resonator predictor."""

from __future__ import annotations

import contextlib
import contextvars
import functools
import hashlib
import math
from collections import OrderedDict
from dataclasses import dataclass

import numpy as np

from synth import dsp
from synth.analysis.clipping import long_runs, runs
from synth.analysis.options import MAX_ORDER
from synth.compilation import compiled

#: Least prediction error energy of the resonator's predictor counted by its order
#: criterion, relative to the stretch's energy (120 dB of prediction gain; below, rounding).
PREDICTION_FLOOR = 1e-12
#: Orders on the geometric grid over which the resonator's order criterion is evaluated.
ORDER_GRID = 96
#: Least error energy, relative to the stretch's, taken from the normal equations' quadratic form
#: (:func:`_quadratic_energies`): the form cancels to it from terms of the stretch's energy, with
#: the factor's rounding (about 1e-13 of that at order 4096), so above this it is within 1e-5 of
#: the error formed from the samples: the description length moves by under a third of one
#: order's cost (``N 1e-5 < ln N`` up to 1e6 samples).
QUADRATIC_CLEAR = 1e-8
#: Predictors whose errors are formed at once (memory: as many transforms).
ERROR_BATCH = 16
#: Resonator predictors kept within :func:`predictors_reused`, the least recently asked for
#: dropped first (at most 32 KB each).
REUSED_PREDICTORS = 128

#: The predictors of :func:`predictors_reused`'s context by their stretch, or None outside one.
_REUSED: contextvars.ContextVar[OrderedDict | None] = contextvars.ContextVar(
    "reused_predictors", default=None
)


def whitening_predictor(
    x: np.ndarray, order: int, samplerate: float, parts: dict | None = None
) -> np.ndarray:
    """Step 1's prediction-error filter of ``x`` (rate ``samplerate``, Hz), loaded so no band is
    lifted past the noise floor; ``parts``: shared terms."""
    r = dsp.white_noise_corrected(dsp.autocorrelation(x, order, parts))
    return dsp.levinson_predictor(r + noise_floor_loading(r, lead_in_noise(x, samplerate), x.size))


def lead_in_noise(x: np.ndarray, samplerate: float) -> float:
    """Noise floor of ``x`` (rate ``samplerate``, Hz) where it starts in noise, else 0 (a render's
    quietest frames are ringing)."""
    fr = dsp.noise_frames(x, samplerate)
    if fr.shape[0] < 2:
        return 0.0
    power = np.mean(fr**2, axis=1)
    quiet = dsp.quiet_frames(power)
    return float(np.sqrt(power[quiet].mean())) if quiet[0] else 0.0


def noise_floor_loading(r: np.ndarray, noise: float, n: int) -> np.ndarray:
    """What to add to the autocorrelation ``r`` (lags ``0..p``, ``n`` samples) so that its spectrum
    (Blackman-Tukey, Parzen window) is nowhere under ``noise^2`` (RMS, signal units)."""
    from scipy.fft import irfft, next_fast_len, rfft

    p = r.size - 1
    floor = float(noise) ** 2
    if p < 1 or n < 1 or not floor > 0.0:
        return np.zeros_like(r)
    nfft = next_fast_len(8 * (p + 1), real=True)
    lags = np.zeros(nfft)
    lags[: p + 1] = r * _parzen(p)
    lags[nfft - p :] = lags[p:0:-1]
    deficit = np.maximum(floor - rfft(lags).real / n, 0.0)
    if not np.any(deficit):
        return np.zeros_like(r)
    return n * irfft(deficit, nfft)[: p + 1]


def _parzen(p: int) -> np.ndarray:
    """The one-sided Parzen lag window over lags ``0..p`` (zero beyond ``p``)."""
    u = np.arange(p + 1) / (p + 1)
    return np.where(u <= 0.5, 1.0 - 6.0 * u**2 + 6.0 * u**3, 2.0 * (1.0 - u) ** 3)


def whiten(x: np.ndarray, predictor: np.ndarray) -> np.ndarray:
    """Prediction error of ``x`` under ``predictor``; 0 over digital silences, where it would be a
    cut-off sound's continuation."""
    from scipy.signal import oaconvolve

    r = oaconvolve(x, predictor)[: x.size]
    r[long_runs(x == 0.0, predictor.size)] = 0.0
    return r


def silence_floor(r: np.ndarray, frame: int, span: int) -> float:
    """Level (RMS over ``frame``) of the whitened ``r`` before its digital silences: the median of
    the largest frame energy over ``span`` before each (0 without)."""
    levels = [
        float(np.convolve(r[a - span : a] ** 2, np.ones(frame), "valid").max())
        for a, b in runs(r == 0.0)
        if b - a >= frame and a >= span
    ]
    return math.sqrt(float(np.median(levels)) / frame) if levels else 0.0


@dataclass(frozen=True)
class _OrderCriterion:
    """Description lengths ``N ln(E_m / N) + m ln N`` of the orders ``grid``, their error energies,
    and ``y`` giving each predictor."""

    grid: np.ndarray
    energy: np.ndarray
    length: np.ndarray
    y: np.ndarray


@contextlib.contextmanager
def predictors_reused():
    """A context in which :func:`resonator_predictor` gives the predictor of a stretch it has
    solved for already again (a copy): a recording's searches fit the same stretches more than
    once (a drop searched on its own repeats the whole recording's search of its first
    bounce). A stretch is known by its samples' digest (BLAKE2b, 128 bits), ``fs`` and
    ``start``; the outermost context holds the predictors, at most :data:`REUSED_PREDICTORS`."""
    token = _REUSED.set(_REUSED.get() if _REUSED.get() is not None else OrderedDict())
    try:
        yield
    finally:
        _REUSED.reset(token)


def resonator_predictor(seg: np.ndarray, fs: float, start: int) -> np.ndarray | None:
    """Covariance-method predictor of the free ringing ``seg`` (rate ``fs``, Hz) of the stable order
    of least description length (Rissanen 1983, Ann. Stat. 11, 416), solved with the least error
    as ridge (:func:`_solved_predictor`); None when too short or unstable. Within
    :func:`predictors_reused`, a stretch solved for already is not solved again."""
    memo = _REUSED.get()
    if memo is None:
        return _solved_predictor(seg, fs, start)
    samples = np.ascontiguousarray(seg, dtype=float)
    key = (samples.size, float(fs), int(start), hashlib.blake2b(samples, digest_size=16).digest())
    if key in memo:
        memo.move_to_end(key)
    else:
        memo[key] = _solved_predictor(samples, fs, start)
        if len(memo) > REUSED_PREDICTORS:
            memo.popitem(last=False)
    a = memo[key]
    return None if a is None else a.copy()


def _solved_predictor(seg: np.ndarray, fs: float, start: int) -> np.ndarray | None:
    """:func:`resonator_predictor` solved for: the order doubled from ``start`` while the least
    description length lies in the top quarter of the orders tried. The normal equations enter
    by their border only (:func:`~synth.dsp.covariance_border`, all the Schur algorithm takes);
    every factor is laid in one buffer, whose pages are touched once."""
    cap = min(MAX_ORDER, (seg.size - 1) // 3)
    if cap < 2 or not np.any(seg):
        return None
    p_max = min(cap, max(start, 2))
    space = np.empty(cap * cap)
    while True:
        C = dsp.covariance_border(seg, p_max)
        ridge = 1e-12 * C.diagonal[1:].sum() / p_max
        f = _border_cholesky(seg, C, ridge, space)
        if f is None:
            return None
        with one_blas_thread():
            crit = _order_criterion(seg, f.L, C.row0, f.load)
        best = int(crit.grid[int(np.argmin(crit.length))])
        if best <= 0.75 * p_max or p_max >= cap:
            break
        p_max = min(cap, 2 * p_max)
    f = _border_cholesky(seg, C, max(float(crit.energy.min()), ridge), space)
    if f is None:
        return None
    with one_blas_thread():
        crit = _order_criterion(seg, f.L, C.row0, f.load)
        for i in np.argsort(crit.length, kind="stable"):
            a = _predictor(f.L, crit.y, int(crit.grid[i]))
            if dsp.is_minimum_phase(a):
                return a
    return None


#: How many :func:`one_blas_thread` contexts are open (the BLAS limit is the process').
_BLAS_DEPTH = [0]


@contextlib.contextmanager
def one_blas_thread():
    """A context running BLAS on one thread: helper threads on busy cores made the many small
    solutions several times as costly. The outermost one sets it."""
    _BLAS_DEPTH[0] += 1
    try:
        if _BLAS_DEPTH[0] > 1:
            yield
        else:
            with _blas_controller().limit(limits=1, user_api="blas"):
                yield
    finally:
        _BLAS_DEPTH[0] -= 1


@functools.cache
def _blas_controller():
    """The thread-pool controller of the BLAS libraries numpy and scipy loaded (scanned once)."""
    import scipy.linalg  # noqa: F401  (its LAPACK and BLAS loaded before the scan)
    from threadpoolctl import ThreadpoolController

    return ThreadpoolController()


@dataclass(frozen=True)
class _Factor:
    """A Cholesky factor ``L`` of a normal matrix plus ``load`` (the ridge it holds) on its
    diagonal."""

    L: np.ndarray
    load: float


def _border_cholesky(
    seg: np.ndarray, border: dsp.CovarianceBorder, load: float, space: np.ndarray
) -> _Factor | None:
    """Cholesky factor (Schur or LAPACK, :func:`_factor`) of the normal matrix of ``seg`` whose
    border is ``border`` plus ``load``, or None; the whole matrix is formed only where LAPACK
    must factor it; ``space``: a buffer for the Schur factor."""
    p = border.row0.size - 1
    whole: list[np.ndarray] = []

    def matrix() -> np.ndarray:
        if not whole:
            whole.append(dsp.covariance_matrix(seg, p)[1:, 1:])
        return whole[0]

    return _factor(border.row1[1:], matrix, seg, load, space)


def _factor(first_row: np.ndarray, matrix, seg: np.ndarray, load: float, space) -> _Factor | None:
    """Cholesky factor of the normal matrix (first row ``first_row``; ``matrix()`` gives it
    whole) plus ``load``: Schur's, else LAPACK's, the load raised 100 times where both fail."""
    from scipy.linalg import LinAlgError, cholesky

    n = first_row.size
    for _ in range(4):
        L = _schur_cholesky(first_row, _displacement_columns(seg, n), load, space)
        if L is not None:
            return _Factor(L, load)
        loaded = matrix().copy()  # the load on the diagonal in place: no n-by-n identity and sum
        loaded.flat[:: n + 1] += load
        try:
            return _Factor(cholesky(loaded, lower=True, check_finite=False, overwrite_a=True), load)
        except LinAlgError:
            load *= 100.0
    return None


def _displacement_columns(seg: np.ndarray, p: int) -> tuple[np.ndarray, np.ndarray]:
    """The samples by which the normal matrix of order ``p`` changes along its diagonals: ``G[k+1,
    l+1] - G[k, l] = a_k a_l - b_k b_l``, ``a_k = seg[p-2-k]``, ``b_k = seg[N-2-k]``."""
    n = seg.size
    a = np.ascontiguousarray(seg[p - 2 :: -1][: p - 1]) if p >= 2 else np.zeros(0)
    b = np.ascontiguousarray(seg[n - 2 :: -1][: p - 1]) if p >= 2 else np.zeros(0)
    return a, b


def _schur_cholesky(
    first_row: np.ndarray, columns, load: float, space: np.ndarray | None = None
) -> np.ndarray | None:
    """Cholesky factor of ``G + load I`` by :func:`_schur_kernel` (in ``space`` where given), or
    None."""
    a, b = columns
    p = first_row.size
    U = (np.empty(p * p) if space is None else space[: p * p]).reshape(p, p)
    ok = _schur_kernel(np.ascontiguousarray(first_row, dtype=float), a, b, float(load), U)
    return U.T if ok else None


@compiled()
def _schur_kernel(row, a, b, load, U):  # pragma: no cover - compiled
    """Generalized Schur algorithm (Kailath and Sayed 1995, SIAM Rev. 37, 297; Bojanczyk et al.
    1995, SIAM J. Matrix Anal. Appl. 16, 40) into ``U``; False on breakdown. Each step's two
    Givens rotations and hyperbolic rotation run in one pass over the generators, and the first
    generator's shift down is an offset into it (``g1[i]`` of step ``k`` is ``h1[i - k]``)."""
    p = row.size
    d = row[0] + load
    if not d > 0.0:
        return False
    h1 = np.empty(p)
    g2 = np.empty(p)
    g3 = np.zeros(p)
    g4 = np.zeros(p)
    s = math.sqrt(d)
    for i in range(p):
        h1[i] = row[i] / s
        g2[i] = row[i] / s
    h1[0] = d / s
    g2[0] = 0.0
    for i in range(p - 1):
        g3[i + 1] = a[i]
        g4[i + 1] = b[i]
    for k in range(p):
        turn1, c1, s1 = _givens_angle(h1[0], g3[k])
        turn2, c2, s2 = _givens_angle(g2[k], g4[k])
        u = c1 * h1[0] + s1 * g3[k] if turn1 else h1[0]
        v = c2 * g2[k] + s2 * g4[k] if turn2 else g2[k]
        if not abs(v) < abs(u):
            return False
        rho = v / u
        c = math.sqrt((1.0 - rho) * (1.0 + rho))
        sign = 1.0 if (u - rho * v) / c > 0.0 else -1.0
        for i in range(k):
            U[k, i] = 0.0
        if turn1 and turn2:
            _schur_step(h1, g2, g3, g4, U[k], k, (c1, s1, c2, s2, rho, c, sign))
            continue
        for i in range(k, p):
            x1 = h1[i - k]
            if turn1:
                y = g3[i]
                x1, g3[i] = c1 * x1 + s1 * y, c1 * y - s1 * x1
            x2 = g2[i]
            if turn2:
                y = g4[i]
                x2, g4[i] = c2 * x2 + s2 * y, c2 * y - s2 * x2
            x = (x1 - rho * x2) / c
            g2[i] = c * x2 - rho * x
            h1[i - k] = x
            U[k, i] = sign * x
    return True


@compiled()
def _schur_step(h1, g2, g3, g4, row, k, turns):  # pragma: no cover - compiled
    """Step ``k`` of :func:`_schur_kernel` where both Givens rotations turn (``turns``: their
    cosines and sines, the hyperbolic rotation's ``rho`` and ``c``, the row's sign) into
    ``row``: one loop without branches."""
    c1, s1, c2, s2, rho, c, sign = turns
    p = g2.size
    for i in range(k, p):
        x1 = h1[i - k]
        y1 = g3[i]
        x2 = g2[i]
        y2 = g4[i]
        u = c1 * x1 + s1 * y1
        g3[i] = c1 * y1 - s1 * x1
        v = c2 * x2 + s2 * y2
        g4[i] = c2 * y2 - s2 * x2
        x = (u - rho * v) / c
        g2[i] = c * v - rho * x
        h1[i - k] = x
        row[i] = sign * x


@compiled()
def _givens_angle(x, y):  # pragma: no cover - compiled
    """Whether to rotate ``(x, y)`` so that ``y`` becomes zero, and the rotation's cosine and
    sine (no turn where either is zero)."""
    h = math.hypot(x, y)
    if h == 0.0 or y == 0.0:
        return False, 1.0, 0.0
    return True, x / h, y / h


def _predictor(Lc: np.ndarray, y: np.ndarray, order: int) -> np.ndarray:
    """Prediction-error filter of ``order`` from the leading block of ``Lc``."""
    return _predictors(Lc, y, np.array([order]))[0]


def _predictors(Lc: np.ndarray, y: np.ndarray, orders: np.ndarray) -> list[np.ndarray]:
    """Prediction-error filters of each of ``orders``, in one compiled pass."""
    U = Lc.T if Lc.T.flags.c_contiguous else np.ascontiguousarray(Lc.T)
    orders = np.asarray(orders, dtype=np.int64)
    out = np.zeros((orders.size, int(orders.max()) + 1))
    _back_substitutions(U, np.ascontiguousarray(y, dtype=float), orders, out)
    return [out[i, : orders[i] + 1] for i in range(orders.size)]


@compiled()
def _back_substitutions(U, y, orders, out):  # pragma: no cover - compiled
    """Row ``g`` of ``out``: ``[1, -h]`` with ``U[:m, :m] h = y[:m]``, ``m = orders[g]``. The
    orders, ranked by decreasing ``m``, in fours side by side, row by row from the last: four
    sums in flight rather than one (each waits on its last addition), each over the same terms
    in the same order as alone."""
    n = orders.size
    rank = np.argsort(-orders, kind="mergesort")
    m = orders[rank]
    h = np.zeros((n, m[0] + 1))  # h[r, j]: out[rank[r], j + 1]
    for i in range(m[0] - 1, -1, -1):
        d = U[i, i]
        r = 0
        while r < n and m[r] > i:
            if r + 3 < n and m[r + 3] > i:
                _four_rows(U, y, m, h, i, r, d)
                r += 4
            else:
                acc = y[i]
                for j in range(i + 1, m[r]):
                    acc += U[i, j] * h[r, j]
                h[r, i] = -acc / d
                r += 1
    for r in range(n):
        g = rank[r]
        out[g, 0] = 1.0
        for j in range(m[r]):
            out[g, j + 1] = h[r, j]


@compiled()
def _four_rows(U, y, m, h, i, r, d):  # pragma: no cover - compiled
    """Row ``i`` of the orders ``r .. r + 3`` (``m`` decreasing) of :func:`_back_substitutions`."""
    a0 = y[i]
    a1 = y[i]
    a2 = y[i]
    a3 = y[i]
    for j in range(i + 1, m[r + 3]):
        u = U[i, j]
        a0 += u * h[r, j]
        a1 += u * h[r + 1, j]
        a2 += u * h[r + 2, j]
        a3 += u * h[r + 3, j]
    for j in range(max(i + 1, m[r + 3]), m[r + 2]):
        u = U[i, j]
        a0 += u * h[r, j]
        a1 += u * h[r + 1, j]
        a2 += u * h[r + 2, j]
    for j in range(max(i + 1, m[r + 2]), m[r + 1]):
        u = U[i, j]
        a0 += u * h[r, j]
        a1 += u * h[r + 1, j]
    for j in range(max(i + 1, m[r + 1]), m[r]):
        a0 += U[i, j] * h[r, j]
    h[r, i] = -a0 / d
    h[r + 1, i] = -a1 / d
    h[r + 2, i] = -a2 / d
    h[r + 3, i] = -a3 / d


def _order_criterion(
    seg: np.ndarray, Lc: np.ndarray, row0: np.ndarray, load: float
) -> _OrderCriterion:
    """Description lengths of the predictors on a geometric grid of orders; ``row0``: row 0 of
    the normal equations, ``load`` the ridge ``Lc`` factors. The error energies are the normal
    equations' own (:func:`_quadratic_energies`, no pass over the samples) where they stand clear
    of their rounding, else formed from the samples (:func:`_error_energies`)."""
    from scipy.linalg import solve_triangular

    p = Lc.shape[0]
    y = solve_triangular(Lc, row0[1:], lower=True, check_finite=False)
    n = seg.size - p
    grid = np.unique(np.round(np.geomspace(1, p, ORDER_GRID)).astype(int))
    predictors = _predictors(Lc, y, grid)
    energy = _quadratic_energies(row0[0], y, predictors, grid, load)
    if energy is None:
        energy = _error_energies(seg, predictors, p)
    energy = np.maximum(energy, PREDICTION_FLOOR * row0[0])
    return _OrderCriterion(grid, energy, n * np.log(energy / n) + grid * math.log(n), y)


def _quadratic_energies(
    c00: float, y: np.ndarray, predictors: list, grid: np.ndarray, load: float
) -> np.ndarray | None:
    """Error energies of ``predictors`` (orders ``grid``) from the normal equations: the order-m
    predictor ``[1, -h]`` solves ``(C_m + load I) h = c_m`` and leaves ``c00 - |y_m|^2 -
    load |h|^2`` (``y = L^-1 c``; the factor's leading block is order m's). None where the
    least lies under :data:`QUADRATIC_CLEAR` of ``c00``: the sum cancels to it from terms of
    ``c00``'s size, and its rounding would move the order chosen."""
    explained = np.cumsum(np.square(y))[grid - 1]
    ridge = np.array([load * float(np.dot(a[1:], a[1:])) for a in predictors])
    energy = c00 - explained - ridge
    if not energy.min() > QUADRATIC_CLEAR * c00:
        return None
    return energy


def _error_energies(seg: np.ndarray, predictors: list, p: int) -> np.ndarray:
    """Error energies of ``seg`` under ``predictors`` by FFT, in batches."""
    from scipy import fft

    nfft = fft.next_fast_len(seg.size + p, real=True)
    spectrum = fft.rfft(seg, nfft)
    out = np.empty(len(predictors))
    for lo in range(0, len(predictors), ERROR_BATCH):
        batch = predictors[lo : lo + ERROR_BATCH]
        taps = np.zeros((len(batch), p + 1))
        for i, a in enumerate(batch):
            taps[i, : a.size] = a
        err = fft.irfft(fft.rfft(taps, nfft, axis=1) * spectrum, nfft, axis=1)[:, p : seg.size]
        out[lo : lo + len(batch)] = np.einsum("ij,ij->i", err, err)
    return out
