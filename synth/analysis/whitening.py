"""Step 1 (docs/analysis.md, Method): whitening by a linear predictor (Makhoul 1975, Proc. IEEE 63,
561; Stowell and Plumbley 2007, ICMC), and step 7's resonator predictor."""

from __future__ import annotations

import contextlib
import functools
import math
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
#: Predictors whose errors are formed at once (memory: as many transforms).
ERROR_BATCH = 16


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


def resonator_predictor(seg: np.ndarray, fs: float, start: int) -> np.ndarray | None:
    """Covariance-method predictor of the free ringing ``seg`` (rate ``fs``, Hz) of the stable order
    of least description length (Rissanen 1983, Ann. Stat. 11, 416), solved with the least error
    as ridge; None when too short or unstable."""
    cap = min(MAX_ORDER, (seg.size - 1) // 3)
    if cap < 2 or not np.any(seg):
        return None
    p_max = min(cap, max(start, 2))
    while True:
        C = dsp.covariance_matrix(seg, p_max)
        G = C[1:, 1:]
        Lc = _loaded_cholesky(G, seg, 1e-12 * np.trace(G) / p_max)
        if Lc is None:
            return None
        with one_blas_thread():
            crit = _order_criterion(seg, Lc, C)
        best = int(crit.grid[int(np.argmin(crit.length))])
        if best <= 0.75 * p_max or p_max >= cap:
            break
        p_max = min(cap, 2 * p_max)
    Lc = _loaded_cholesky(G, seg, max(float(crit.energy.min()), 1e-12 * np.trace(G) / p_max))
    if Lc is None:
        return None
    with one_blas_thread():
        crit = _order_criterion(seg, Lc, C)
        for i in np.argsort(crit.length, kind="stable"):
            a = _predictor(Lc, crit.y, int(crit.grid[i]))
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


def _loaded_cholesky(G: np.ndarray, seg: np.ndarray, load: float) -> np.ndarray | None:
    """Cholesky factor of ``G`` plus ``load`` (Schur or LAPACK), or None."""
    from scipy.linalg import LinAlgError, cholesky

    n = G.shape[0]
    for _ in range(4):
        L = _schur_cholesky(G[0], _displacement_columns(seg, n), load)
        if L is not None:
            return L
        loaded = G.copy()  # the load on the diagonal in place: no n-by-n identity and sum
        loaded.flat[:: n + 1] += load
        try:
            return cholesky(loaded, lower=True, check_finite=False, overwrite_a=True)
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


def _schur_cholesky(first_row: np.ndarray, columns, load: float) -> np.ndarray | None:
    """Cholesky factor of ``G + load I`` by :func:`_schur_kernel`, or None."""
    a, b = columns
    U = np.zeros((first_row.size, first_row.size))
    ok = _schur_kernel(np.ascontiguousarray(first_row, dtype=float), a, b, float(load), U)
    return U.T if ok else None


@compiled()
def _schur_kernel(row, a, b, load, U):  # pragma: no cover - compiled
    """Generalized Schur algorithm (Kailath and Sayed 1995, SIAM Rev. 37, 297; Bojanczyk et al.
    1995, SIAM J. Matrix Anal. Appl. 16, 40) into ``U``; False on breakdown."""
    p = row.size
    d = row[0] + load
    if not d > 0.0:
        return False
    g1 = np.empty(p)
    g2 = np.empty(p)
    g3 = np.zeros(p)
    g4 = np.zeros(p)
    s = math.sqrt(d)
    for i in range(p):
        g1[i] = row[i] / s
        g2[i] = row[i] / s
    g1[0] = d / s
    g2[0] = 0.0
    for i in range(p - 1):
        g3[i + 1] = a[i]
        g4[i + 1] = b[i]
    for k in range(p):
        _givens(g1, g3, k)
        _givens(g2, g4, k)
        u, v = g1[k], g2[k]
        if not abs(v) < abs(u):
            return False
        rho = v / u
        c = math.sqrt((1.0 - rho) * (1.0 + rho))
        for i in range(k, p):
            x = (g1[i] - rho * g2[i]) / c
            g2[i] = c * g2[i] - rho * x
            g1[i] = x
        sign = 1.0 if g1[k] > 0.0 else -1.0
        for i in range(k, p):
            U[k, i] = sign * g1[i]
        for i in range(p - 1, k, -1):
            g1[i] = g1[i - 1]
        g1[k] = 0.0
    return True


@compiled()
def _givens(x, y, k):  # pragma: no cover - compiled
    """Rotate ``x[k:]`` and ``y[k:]`` together so that ``y[k]`` becomes zero."""
    h = math.hypot(x[k], y[k])
    if h == 0.0 or y[k] == 0.0:
        return
    c = x[k] / h
    s = y[k] / h
    for i in range(k, x.size):
        xi = x[i]
        x[i] = c * xi + s * y[i]
        y[i] = c * y[i] - s * xi


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
    """Row ``i`` of ``out``: ``[1, -h]`` with ``U[:m, :m] h = y[:m]``, ``m = orders[i]``."""
    for g in range(orders.size):
        m = orders[g]
        out[g, 0] = 1.0
        for i in range(m - 1, -1, -1):
            acc = y[i]
            for j in range(i + 1, m):
                acc += U[i, j] * out[g, j + 1]
            out[g, i + 1] = -acc / U[i, i]


def _order_criterion(seg: np.ndarray, Lc: np.ndarray, C: np.ndarray) -> _OrderCriterion:
    """Description lengths of the predictors on a geometric grid of orders."""
    from scipy.linalg import solve_triangular

    p = Lc.shape[0]
    y = solve_triangular(Lc, C[1:, 0], lower=True, check_finite=False)
    n = seg.size - p
    grid = np.unique(np.round(np.geomspace(1, p, ORDER_GRID)).astype(int))
    predictors = _predictors(Lc, y, grid)
    energy = np.maximum(_error_energies(seg, predictors, p), PREDICTION_FLOOR * C[0, 0])
    return _OrderCriterion(grid, energy, n * np.log(energy / n) + grid * math.log(n), y)


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
