"""Analysis of bouncing sounds: find the ticks in a recording and measure them.

The measurements are the perceptual parameters of the thesis (see docs/physics.md,
References), Chapter 5 and section 3.1: per tick the onset, the bounce time since the previous
tick, the restitution ``e_n = t_n / t_(n-1)`` and the impact speed ``v_n = g t_n / 2`` that
follow from the bounce times, the tick's energy and peak, its spectral centroid and spread,
and its decay time. docs/analysis.md describes the method step by step and its measured
accuracy.

The stages, one module each:

* :mod:`~synth.analysis.settings`: the checked options (:class:`Settings`) and reading a file;
* :mod:`~synth.analysis.clipping`: clipped samples found and interpolated;
* :mod:`~synth.analysis.whitening`: step 1, and the resonator's own predictor of step 7;
* :mod:`~synth.analysis.detection`: steps 2-4 (detection function, threshold, onsets) and the
  delay that times a tick against a template;
* :mod:`~synth.analysis.series`: the rules of a bounce series (steps 3 and 6);
* :mod:`~synth.analysis.deflation`: step 5, the ticks found one by one with the earlier ones
  taken out; :mod:`~synth.analysis.resonator`: step 7, its variant on the resonator's
  whitening;
* :mod:`~synth.analysis.measures`: each tick's measurements;
* :mod:`~synth.analysis.validity`: the bounce series (drops) of a recording, the
  physically impossible restitutions flagged, input that holds no impact refused;
* :mod:`~synth.analysis.pipeline`: :func:`analyze`, the stages in order;
* :mod:`~synth.analysis.report` and :mod:`~synth.analysis.plotting`: the results and their
  presentation.
"""

from synth.analysis.measures import DECAY_MIN_FALL, DECAY_NOISE_MARGIN_DB, WINDOW_GUARD
from synth.analysis.pipeline import analyze, analyze_file
from synth.analysis.plotting import check_plot_path, plot_analysis
from synth.analysis.report import Analysis, Tick, format_table, to_csv, to_dict
from synth.analysis.resonator import AGREEMENT
from synth.analysis.search import CLEAN_GUARD, RESONATOR_GAIN_DB
from synth.analysis.series import (
    ANCHOR_DB,
    BOUNCE_GROWTH,
    DOUBTFUL_DB,
    MAX_EXCESS_DB,
    RESTITUTION_STEP,
    SERIES_HORIZON,
)
from synth.analysis.settings import (
    DYNAMIC_RANGE_DB,
    MIN_FRAME,
    AnalysisError,
    Settings,
    read_recording,
)
from synth.analysis.validity import MISSED_GROWTH, Series

__all__ = [
    "AGREEMENT",
    "ANCHOR_DB",
    "BOUNCE_GROWTH",
    "CLEAN_GUARD",
    "DECAY_MIN_FALL",
    "DECAY_NOISE_MARGIN_DB",
    "DOUBTFUL_DB",
    "DYNAMIC_RANGE_DB",
    "MAX_EXCESS_DB",
    "MIN_FRAME",
    "MISSED_GROWTH",
    "RESONATOR_GAIN_DB",
    "RESTITUTION_STEP",
    "SERIES_HORIZON",
    "WINDOW_GUARD",
    "Analysis",
    "AnalysisError",
    "Series",
    "Settings",
    "Tick",
    "analyze",
    "analyze_file",
    "check_plot_path",
    "format_table",
    "plot_analysis",
    "read_recording",
    "to_csv",
    "to_dict",
]
