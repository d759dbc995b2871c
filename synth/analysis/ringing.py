"""Step 9 (docs/analysis.md): a burst the ringing explains is no impact. The ringing's predictor
models its modes (Prony's method, Kumaresan and Tufts 1982, IEEE Trans. ASSP 30, 833): an impact
raises its error, beating modes do not."""

from __future__ import annotations

import math

import numpy as np

from synth import dsp
from synth.analysis.detection import STANDS_OUT_BEFORE, STANDS_OUT_SPAN, noise_rise, rise_at
from synth.analysis.measures import WINDOW_GUARD
from synth.analysis.settings import Settings
from synth.analysis.whitening import one_blas_thread

#: The ringing is fitted over at most this much before a tick, s: a predictor of a third of its
#: samples resolves 80 modes over 10 ms at 48 kHz, at a cost cubic in the order.
RINGING_FIT = 0.01
#: Ridge on the ringing predictor's normal equations, relative to their mean diagonal: 120 dB of
#: prediction gain (as :data:`~synth.analysis.whitening.PREDICTION_FLOOR`).
RIDGE = 1e-12


def ringing_explained(
    x: np.ndarray, free: int, onset: float, s: Settings, innovation: float
) -> bool:
    """Whether the burst at ``onset`` is explained by the ringing free from ``free``: modes fitted
    over :data:`RINGING_FIT` predict it within step 8's F quantile, or it peaks
    ``dynamic_range_db`` under ``innovation``. False where it cannot be judged."""
    from scipy.signal import lfilter

    from synth.analysis.search import RESONATOR_GAIN_DB  # step 7's gain: search imports this

    fs = s.samplerate
    span = max(1, int(round(STANDS_OUT_SPAN * fs)))
    held = max(1, int(round(STANDS_OUT_BEFORE * fs)))
    on = int(math.floor(onset)) - WINDOW_GUARD
    end = on - held
    start = max(free, end - int(round(RINGING_FIT * fs)))
    if end - start < span or on + span > x.size:
        return False
    a = ringing_predictor(x[start:end])
    if a is None:
        return False
    e = lfilter(a, [1.0], x[end - a.size + 1 : on + span])[a.size - 1 :]
    # a short fit models the ringing only where its error over the held-out stretch is
    # RESONATOR_GAIN_DB under the ringing there
    gain = 10.0 ** (RESONATOR_GAIN_DB / 10.0)
    if end - start < int(round(RINGING_FIT * fs)) and not (
        np.dot(x[end:on], x[end:on]) > gain * np.dot(e[:held], e[:held])
    ):
        return False
    floor = innovation * 10.0 ** (-s.dynamic_range_db / 20.0)
    return rise_at(e, held, span, held) < noise_rise(span, held) or not (
        np.max(np.abs(e[held:])) > floor
    )


def ringing_predictor(seg: np.ndarray) -> np.ndarray | None:
    """Covariance-method prediction-error filter of ``seg``, order a third of its samples, ridge
    :data:`RIDGE`; None where silent."""
    from scipy.linalg import LinAlgError, cho_factor, cho_solve

    p = (seg.size - 1) // 3
    C = dsp.covariance_matrix(seg, p)
    G = C[1:, 1:]
    load = RIDGE * np.trace(G) / p
    if not load > 0.0:
        return None
    G[np.diag_indices(p)] += load
    try:
        with one_blas_thread():
            a = cho_solve(cho_factor(G, check_finite=False), -C[1:, 0], check_finite=False)
    except LinAlgError:
        return None
    return np.r_[1.0, a]
