"""Analysis of bouncing sounds: find the ticks in a recording and measure them, per tick the
perceptual parameters of the thesis (docs/physics.md, References; Chapter 5 and section 3.1):
onset, bounce time, restitution ``e_n = t_n / t_(n-1)``, impact speed ``v_n = g t_n / 2``,
energy, peak, spectral centroid and spread, decay time. docs/analysis.md describes the method
step by step, its measured accuracy and the module of each stage."""

from synth.lazy import lazy_names

#: Where each public name lives, imported on first use (PEP 562): the command line reads the
#: options' declaration without loading the analysis.
_LAZY = {
    name: module
    for module, names in (
        ("options", ("AnalysisOptions", "DYNAMIC_RANGE_DB")),
        ("settings", ("AnalysisError", "MIN_FRAME", "read_recording")),
        ("series", ("ANCHOR_DB", "BOUNCE_GROWTH", "DOUBTFUL_DB", "MAX_EXCESS_DB")),
        ("series", ("RESTITUTION_STEP", "SERIES_HORIZON")),
        ("search", ("CLEAN_GUARD", "RESONATOR_GAIN_DB")),
        ("resonator", ("AGREEMENT",)),
        ("measures", ("DECAY_MIN_FALL", "DECAY_NOISE_MARGIN_DB", "WINDOW_GUARD")),
        ("validity", ("MISSED_GROWTH", "Series")),
        ("report", ("Analysis", "Tick", "format_table", "to_csv", "to_dict")),
        ("pipeline", ("analyze", "analyze_file")),
        ("report", ("check_plot_path", "plot_analysis")),
    )
    for name in names
}

__all__ = list(_LAZY)


__getattr__, __dir__ = lazy_names(__name__, _LAZY)
