"""The plate's ringing before a tick, modelled from the recording itself (docs/analysis.md,
Method, step 9): a burst that the ringing explains is no impact.

Between two impacts the recording is the free ringing of the plate, a sum of exponentially
decaying modes. The linear predictor of that stretch by the covariance method (least squares,
no window) is the model of those modes: its poles are their frequencies and dampings, the
stretch's own samples their amplitudes and phases (Prony's method as linear prediction,
Kumaresan and Tufts 1982, IEEE Trans. ASSP 30, 833). Run over the next samples, its prediction
error is what the ringing does not explain. An impact adds a broadband contact force that no
past ringing predicts, and its error rises at its onset; a burst of beating modes, which a
20 ms predictor of the whole recording cannot follow, is the ringing itself and leaves no more
error than the ringing just before it. The decision weighs that error's mean square over the
tick's first :data:`~synth.analysis.detection.STANDS_OUT_SPAN` against that over the
:data:`~synth.analysis.detection.STANDS_OUT_BEFORE` held out before the onset, both predicted
by the model fitted before them: a tick must rise over it by more than white noise's
scatter allows, the F quantile of step 8 (:func:`~synth.analysis.detection.standing_out`).
A weak impact late in a series rises over the ringing by a few dB only, so no larger margin
is asked; the modes a short stretch cannot resolve leave some bursts of a plate of
thousands of modes unexplained.
"""

from __future__ import annotations

import math

import numpy as np

from synth import dsp
from synth.analysis.detection import (
    STANDS_OUT_BEFORE,
    STANDS_OUT_SPAN,
    noise_rise,
    rise_at,
)
from synth.analysis.measures import WINDOW_GUARD
from synth.analysis.settings import Settings
from synth.analysis.whitening import one_blas_thread

#: The ringing is fitted over at most this much of the stretch before a tick, s: the
#: covariance method resolves as many modes as a sixth of its samples (a predictor of a
#: third of them, two poles per mode; two equations per unknown, at least), 80 over 10 ms
#: at 48 kHz, at a cost of the cube of that order per tick.
RINGING_FIT = 0.01
#: The ridge on the normal equations of the ringing's predictor, relative to their mean
#: diagonal: 120 dB of prediction gain (as the resonator's predictor's floor,
#: :data:`~synth.analysis.whitening.PREDICTION_FLOOR`); below, rounding.
RIDGE = 1e-12


def ringing_explained(
    x: np.ndarray, free: int, onset: float, s: Settings, innovation: float
) -> bool:
    """Whether the burst at ``onset`` (sample of ``x``) is explained by the ringing before it,
    free from sample ``free`` on (past the previous contact): the decaying modes fitted to
    the last :data:`RINGING_FIT` of ``x`` up to
    :data:`~synth.analysis.detection.STANDS_OUT_BEFORE` and
    :data:`~synth.analysis.measures.WINDOW_GUARD` before ``onset``, predicted over the
    held-out stretch before the onset and the tick's first
    :data:`~synth.analysis.detection.STANDS_OUT_SPAN`; explained when the prediction error
    does not rise from the one to the other by more than white noise's scatter allows (the
    F quantile of step 8), or where that error peaks more than ``dynamic_range_db`` under
    ``innovation``, the largest magnitude of the recording's whitened signal (step 1: the
    strongest impact's contact force, as it shows in a prediction error): what the tick adds
    to the ringing lies outside the dynamic range of the recording's impacts (a rise of the
    error of a prediction good to the recording's rounding is none of an impact).
    Where less than :data:`RINGING_FIT` of free ringing precedes the held-out stretch (a fast
    chatter), the fit takes what there is, the predictor's order a third of it, and explains
    a burst only where it models the ringing (:func:`_predicts`): a fit of a few modes over a
    plate of many leaves an error that a fast chatter's true contacts rise over no more than
    the ringing's bursts. False (not
    explained) where that stretch is shorter than the tick's first
    :data:`~synth.analysis.detection.STANDS_OUT_SPAN` it predicts, or silent: nothing is
    dropped that cannot be judged.
    """
    from scipy.signal import lfilter

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
    if end - start < int(round(RINGING_FIT * fs)) and not _predicts(x[end:on], e[:held]):
        return False
    floor = innovation * 10.0 ** (-s.dynamic_range_db / 20.0)
    return rise_at(e, held, span, held) < noise_rise(span, held) or not (
        np.max(np.abs(e[held:])) > floor
    )


def _predicts(held: np.ndarray, error: np.ndarray) -> bool:
    """Whether a fit over a short free stretch models the ringing: its error over the
    held-out stretch ``held`` leaves at least
    :data:`~synth.analysis.search.RESONATOR_GAIN_DB` less than the ringing itself, the gain
    by which step 7 takes a predictor for a model of the ringing."""
    from synth.analysis.search import RESONATOR_GAIN_DB

    gain = 10.0 ** (RESONATOR_GAIN_DB / 10.0)
    return bool(np.dot(held, held) > gain * np.dot(error, error))


def ringing_predictor(seg: np.ndarray) -> np.ndarray | None:
    """The prediction-error filter ``[1, a1, ..., ap]`` of the free ringing ``seg`` by the
    covariance method, of order a third of its samples (two equations per unknown, at
    least): as many modes as the stretch can resolve. Its one-step prediction error is
    formed, never its impulse response, so neither its stability nor an order criterion
    matters: an order too high for the noise raises the error alike over the stretches it
    compares. The normal equations carry a ridge of :data:`RIDGE` of their mean diagonal
    (a stretch of fewer modes than the order). None where the stretch is silent."""
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
