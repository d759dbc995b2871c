"""Step 1 of the tick detection (docs/analysis.md, Method): the whitening of the recording by a
linear predictor, and the resonator's own predictor of step 7.

The prediction error ``r = A(z) x`` (the recording taken as silent before its first sample) is
the inverse filter of linear-prediction analysis (Makhoul 1975, Proc. IEEE 63, 561), used as
the whitening step of an onset detector (Stowell and Plumbley 2007, ICMC): the ringing of a
tick is predictable from its own past and largely cancels, leaving one short burst per
contact.
"""

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
#: Predictors whose prediction errors are formed at once by the order criterion (memory:
#: this many transforms of the stretch).
ERROR_BATCH = 16


def whitening_predictor(
    x: np.ndarray, order: int, samplerate: float, parts: dict | None = None
) -> np.ndarray:
    """Step 1's prediction-error filter ``[1, a1, ..., ap]`` of ``x`` (sample rate
    ``samplerate``, Hz): the autocorrelation method (:func:`synth.dsp.autocorrelation`, with
    its white-noise correction), the recording's noise floor taken as the least power
    spectral density it holds (:func:`noise_floor_loading`).

    A predictor lifts each band by about the inverse of its power. A band the recording does
    not hold (above a lossy encoder's lowpass, under an anti-aliasing filter) would be lifted
    by up to the white-noise correction, 90 dB, far over the noise: a step at the recording's
    cut, or any small error there, then whitens to a burst taken for a tick. No band of a
    recording is known to better than its noise floor, so none is lifted beyond it
    (:func:`lead_in_noise`); a band that holds noise or sound is left as it is, and a
    recording without noise before its first sound (a render) is whitened as without the
    floor. ``parts``: the autocorrelation's terms of a signal that ``x`` starts (see
    :func:`synth.dsp.autocorrelation`), shared by the searches of a block and of its start."""
    r = dsp.white_noise_corrected(dsp.autocorrelation(x, order, parts))
    return dsp.levinson_predictor(r + noise_floor_loading(r, lead_in_noise(x, samplerate), x.size))


def lead_in_noise(x: np.ndarray, samplerate: float) -> float:
    """The noise floor of ``x`` (sample rate ``samplerate``, Hz; :func:`synth.dsp.noise_floor`,
    signal units) where ``x`` starts in it: its first frame among the quietest, noise before
    the first sound; else 0. The quietest frames of a recording that starts with its first
    sound (a render after a preroll of a few milliseconds) are the end of the ringing, no
    noise: a floor there would lift the bands between the modes, which the whitening must
    lift to leave each contact a short burst."""
    fr = dsp.noise_frames(x, samplerate)
    if fr.shape[0] < 2:
        return 0.0
    power = np.mean(fr**2, axis=1)
    quiet = dsp.quiet_frames(power)
    return float(np.sqrt(power[quiet].mean())) if quiet[0] else 0.0


def noise_floor_loading(r: np.ndarray, noise: float, n: int) -> np.ndarray:
    """What to add to the autocorrelation ``r`` (lags ``0..p``, summed over ``n`` samples) so
    that its power spectral density is nowhere under ``noise^2`` (``noise``: an RMS in signal
    units): the autocorrelation, summed over ``n`` samples, of white noise of that RMS
    filtered to the bands where the spectrum of ``r`` lies under it; zero where none does.

    The spectrum is the Blackman-Tukey estimate of ``r`` under a Parzen lag window (its
    transform is non-negative, so the estimate of a biased autocorrelation is too, and its
    leakage falls as the fourth power of the distance from a mode), per sample: white
    noise of variance ``s^2`` gives ``s^2`` at every frequency."""
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
    """The prediction error of ``x`` under ``predictor`` (``[1, a1, ..., ap]``), the signal
    taken as silent before its first sample; as long as ``x``, and 0 over its digital
    silences (runs of exact zeros at least as long as ``predictor``, which no noise rests
    at): the error there is the predictor's continuation of a sound cut off (a render's
    modes stopped under its omission floor, a gate), a burst no impact made."""
    from scipy.signal import oaconvolve

    r = oaconvolve(x, predictor)[: x.size]
    r[long_runs(x == 0.0, predictor.size)] = 0.0
    return r


def silence_floor(r: np.ndarray, frame: int, span: int) -> float:
    """The level (RMS over ``frame`` samples) under which the whitened signal ``r`` holds
    nothing an impact can be told from where it falls to digital silence (runs of at least
    ``frame`` zeros; 0 where it never does): the median over the silences of the largest
    frame energy over the ``span`` samples before each, which hold the steps by which the
    sound stopped (a render leaves out each mode once all it could add lies under its share
    of an omission floor): the recording's resolution in place of a noise floor."""
    levels = [
        float(np.convolve(r[a - span : a] ** 2, np.ones(frame), "valid").max())
        for a, b in runs(r == 0.0)
        if b - a >= frame and a >= span
    ]
    return math.sqrt(float(np.median(levels)) / frame) if levels else 0.0


@dataclass(frozen=True)
class _OrderCriterion:
    """Description lengths of the predictors of the orders ``grid``: their prediction error
    energies over the same samples (never below :data:`PREDICTION_FLOOR` of the stretch's),
    the criterion ``N ln(E_m / N) + m ln N``, and the forward-substituted right-hand side
    ``y`` from which each order's predictor follows."""

    grid: np.ndarray
    energy: np.ndarray
    length: np.ndarray
    y: np.ndarray


def resonator_predictor(seg: np.ndarray, fs: float, start: int) -> np.ndarray | None:
    """The prediction-error filter of the free ringing ``seg`` by the covariance method
    (least squares over the stretch, no window: a window would bias the poles of slowly
    decaying modes), of the order of least description length ``N ln(E_m / N) + m ln N``
    (Rissanen 1983, Ann. Stat. 11, 416) whose all-pole model is stable; None when the stretch
    is too short or no order gives a stable model (step 7).

    The orders tried start at ``start`` and double while the best lies in the top quarter, up
    to a third of the stretch (two equations per unknown, at least) and :data:`MAX_ORDER`;
    every predictor comes from one Cholesky factorisation at the largest order (its leading
    blocks factor the smaller systems; :func:`_loaded_cholesky`, O(p^2)). Then the normal
    equations are solved again with the least prediction error energy on their diagonal: the
    noise, which no order predicts, as white noise (a ridge), so that no predictor lifts a
    band the ringing leaves empty (above its modes, under an anti-aliasing filter) far over
    the noise, where a tick's onset would drown; without noise it changes nothing. ``fs``
    (Hz) is the sample rate of ``seg``.
    """
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
    """A context in which BLAS and LAPACK run on one thread: for the analysis' small products
    and solutions (a fit's Gram matrix has a few hundred unknowns, and thousands are solved
    per recording; the triangular solutions of the resonator's predictor). The helper threads
    of a multithreaded BLAS, waiting for cores that other work keeps busy, made them three to
    ten times as costly on two shared cores (as the Ritz modes' eigen-solutions, see
    :mod:`synth.physics.modes`). Only the outermost of nested contexts sets the limit (an
    inner one would change nothing), through one controller of the BLAS libraries the
    process loaded (:func:`_blas_controller`): a scan of those libraries takes tens of
    milliseconds, and the analysis enters such a context hundreds of times."""
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
    """The thread-pool controller of the BLAS libraries loaded with numpy and scipy's linear
    algebra (scanned once; both are imported before any analysis runs)."""
    import scipy.linalg  # noqa: F401  (its LAPACK and BLAS loaded before the scan)
    from threadpoolctl import ThreadpoolController

    return ThreadpoolController()


def _loaded_cholesky(G: np.ndarray, seg: np.ndarray, load: float) -> np.ndarray | None:
    """Lower Cholesky factor of ``G`` (the covariance method's normal matrix of ``seg``, less
    its first row and column: :func:`resonator_predictor`) with ``load`` on its diagonal,
    raised a hundredfold up to three times while ``G`` is not positive definite to rounding;
    None if it stays so. The factor comes from the matrix's displacement structure
    (:func:`_schur_cholesky`, O(p^2)); where that algorithm's hyperbolic rotations break down
    (a matrix positive definite only to rounding), from LAPACK's factorisation (O(p^3))."""
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
    """The samples by which the normal matrix ``G`` of order ``p`` of :func:`resonator_predictor`
    changes along its diagonals: ``G[k+1, l+1] - G[k, l] = a_k a_l - b_k b_l`` with ``a_k =
    seg[p-2-k]`` (a sample entering the sums) and ``b_k = seg[N-2-k]`` (one leaving them),
    ``k = 0 .. p-2`` (:func:`synth.dsp.covariance_matrix`'s recursion)."""
    n = seg.size
    a = np.ascontiguousarray(seg[p - 2 :: -1][: p - 1]) if p >= 2 else np.zeros(0)
    b = np.ascontiguousarray(seg[n - 2 :: -1][: p - 1]) if p >= 2 else np.zeros(0)
    return a, b


def _schur_cholesky(first_row: np.ndarray, columns, load: float) -> np.ndarray | None:
    """Lower Cholesky factor of ``G + load I`` from its generator (:func:`_schur_kernel`), or
    None where the matrix is not positive definite to rounding."""
    a, b = columns
    U = np.zeros((first_row.size, first_row.size))
    ok = _schur_kernel(np.ascontiguousarray(first_row, dtype=float), a, b, float(load), U)
    return U.T if ok else None


@compiled()
def _schur_kernel(row, a, b, load, U):  # pragma: no cover - compiled
    """The generalized Schur algorithm (Kailath and Sayed 1995, SIAM Rev. 37, 297) for the
    symmetric matrix ``R`` whose first row is ``row`` (plus ``load`` on its diagonal) and
    whose displacement is ``R[k+1, l+1] - R[k, l] = a_k a_l - b_k b_l``: ``R - Z R Z^T =
    g1 g1^T - g2 g2^T + g3 g3^T - g4 g4^T`` with ``g1 = r / sqrt(d)``, ``g2 = (r - d e_0) /
    sqrt(d)`` (``r`` the loaded first row, ``d = r_0``), ``g3 = (0, a)``, ``g4 = (0, b)``.
    Each step rotates the positive columns together and the negative ones (Givens), then
    the first against the second (a hyperbolic rotation in the mixed form of Bojanczyk,
    Brent, de Hoog and Sweet 1995, SIAM J. Matrix Anal. Appl. 16, 40, backward stable for a
    positive definite ``R``), takes the first as the factor's column and shifts it down.
    Writes the factor's transpose into ``U`` (zeros on entry; its rows are the factor's
    columns, written whole); False where a rotation breaks down (``R`` not positive definite
    to rounding)."""
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
    """The prediction-error filter of ``order`` from the leading block of the factor ``Lc``
    (back substitution of ``y``)."""
    return _predictors(Lc, y, np.array([order]))[0]


def _predictors(Lc: np.ndarray, y: np.ndarray, orders: np.ndarray) -> list[np.ndarray]:
    """The prediction-error filters of each of ``orders`` from the leading blocks of the
    factor ``Lc``: back substitutions of ``y`` in one compiled pass (thousands of small
    ones per recording; a library call each cost more than its arithmetic)."""
    U = Lc.T if Lc.T.flags.c_contiguous else np.ascontiguousarray(Lc.T)
    orders = np.asarray(orders, dtype=np.int64)
    out = np.zeros((orders.size, int(orders.max()) + 1))
    _back_substitutions(U, np.ascontiguousarray(y, dtype=float), orders, out)
    return [out[i, : orders[i] + 1] for i in range(orders.size)]


@compiled()
def _back_substitutions(U, y, orders, out):  # pragma: no cover - compiled
    """Row ``i`` of ``out``: ``[1, -h]`` with ``U[:m, :m] h = y[:m]``, ``m = orders[i]``
    (``U`` upper triangular, its rows read whole)."""
    for g in range(orders.size):
        m = orders[g]
        out[g, 0] = 1.0
        for i in range(m - 1, -1, -1):
            acc = y[i]
            for j in range(i + 1, m):
                acc += U[i, j] * out[g, j + 1]
            out[g, i + 1] = -acc / U[i, i]


def _order_criterion(seg: np.ndarray, Lc: np.ndarray, C: np.ndarray) -> _OrderCriterion:
    """The description length of the predictors on a geometric grid of orders up to the
    factor's, each one's error counted over the same samples (those the largest predicts)."""
    from scipy.linalg import solve_triangular

    p = Lc.shape[0]
    y = solve_triangular(Lc, C[1:, 0], lower=True, check_finite=False)
    n = seg.size - p
    grid = np.unique(np.round(np.geomspace(1, p, ORDER_GRID)).astype(int))
    predictors = _predictors(Lc, y, grid)
    energy = np.maximum(_error_energies(seg, predictors, p), PREDICTION_FLOOR * C[0, 0])
    return _OrderCriterion(grid, energy, n * np.log(energy / n) + grid * math.log(n), y)


def _error_energies(seg: np.ndarray, predictors: list, p: int) -> np.ndarray:
    """The energy of the prediction error of ``seg`` under each of ``predictors`` (at most
    ``p + 1`` taps) over the samples ``p .. seg.size - 1``: the convolutions by one transform
    of ``seg`` and one of each predictor, :data:`ERROR_BATCH` predictors at a time (a
    transform as long as ``seg`` and the longest predictor: no wrap-around)."""
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
