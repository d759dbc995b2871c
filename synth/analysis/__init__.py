"""Analysis of bouncing sounds: find the ticks in a recording and measure them.

The measurements are the perceptual parameters of the thesis (docs/physics.md, References),
Chapter 5 and section 3.1: per tick the onset, bounce time, restitution ``e_n = t_n / t_(n-1)``,
impact speed ``v_n = g t_n / 2``, energy, peak, spectral centroid and spread, and decay time.
docs/analysis.md describes the method step by step and its measured accuracy.

Stages, one module each: options and settings, clipping, whitening (step 1), detection (steps
2-4), series (3, 6), deflation (5), resonator (7), ringing (9), measures, validity, pipeline
(:func:`analyze`), report and plotting."""

from synth.lazy import lazy_names

#: Where each public name lives, imported on first use (PEP 562): the command line reads the
#: options' declaration without loading the analysis.
_LAZY = {
    "AGREEMENT": "resonator",
    "ANCHOR_DB": "series",
    "BOUNCE_GROWTH": "series",
    "CLEAN_GUARD": "search",
    "DECAY_MIN_FALL": "measures",
    "DECAY_NOISE_MARGIN_DB": "measures",
    "DOUBTFUL_DB": "series",
    "DYNAMIC_RANGE_DB": "options",
    "MAX_EXCESS_DB": "series",
    "MIN_FRAME": "settings",
    "MISSED_GROWTH": "validity",
    "RESONATOR_GAIN_DB": "search",
    "RESTITUTION_STEP": "series",
    "SERIES_HORIZON": "series",
    "WINDOW_GUARD": "measures",
    "Analysis": "report",
    "AnalysisError": "settings",
    "AnalysisOptions": "options",
    "Series": "validity",
    "Tick": "report",
    "analyze": "pipeline",
    "analyze_file": "pipeline",
    "check_plot_path": "plotting",
    "format_table": "report",
    "plot_analysis": "plotting",
    "read_recording": "settings",
    "to_csv": "report",
    "to_dict": "report",
}

__all__ = list(_LAZY)


__getattr__, __dir__ = lazy_names(__name__, _LAZY)
