"""The benchmarks: numerical error against run time (``synth bench NAME``, run from a source
checkout; :mod:`benchmarks.cli`). Not installed with the package.

One module per benchmark (contact, render, analysis, long, scale, hires, cold, rolling,
hollow, materials, cost, rules; the live engine's and the sound banks' are :mod:`benchmarks.live` and
:mod:`benchmarks.bank`; the thesis study, ``synth bench thesis``, is the ``validation``
package). :mod:`benchmarks.jack` runs a JACK dummy server for the live benchmark and the
tests; :mod:`benchmarks.docs` writes the figures into docs/. Every figure is measured in
one run on this machine, after a warm-up. The engine (``synth``) imports nothing from here.
The names below are re-exported so that ``benchmarks.NAME`` reaches every benchmark's
public functions (the child processes of ``long``, ``scale`` and ``hires`` call them that
way).
"""

from benchmarks.analysis import format_analysis, run_analysis, synthetic_bounce
from benchmarks.analysis_scenes import format_random, run_random
from benchmarks.cold import format_cold, run_cold
from benchmarks.common import markdown_block
from benchmarks.contact import (
    ContactCase,
    contact_cases,
    format_contact,
    format_modal_contact,
    run_contact,
    run_modal_contact,
    scipy_contact,
)
from benchmarks.cost import format_cost, record_rates, run_cost
from benchmarks.hires import HIRES_RATES, format_hires, hires_child, run_hires
from benchmarks.hollow import format_hollow, run_hollow
from benchmarks.long import format_long, long_child, long_recording, run_long
from benchmarks.materials import format_materials, run_materials
from benchmarks.render import format_render, render_scenes, run_render
from benchmarks.rolling import format_rolling, run_rolling
from benchmarks.rolling_check import format_rolling_check, run_rolling_check
from benchmarks.rules import format_rules, run_rules
from benchmarks.scale import (
    SCALE_LADDER,
    SCALE_NAMED,
    SCALE_RANDOM,
    format_scale,
    random_scale_specs,
    run_scale,
    scale_child,
    scale_scene,
)
from validation import (
    THESIS_IMPACTS,
    THESIS_IMPEDANCE,
    THESIS_RESTITUTION,
    THESIS_TICK_DECAY,
    envelope_decay_time,
    format_surface_fit,
    format_thesis,
    modal_critical_distance,
    surface_fit,
    thesis_comparison,
    thesis_lowspeed_rows,
    thesis_modal_rows,
    thesis_row,
    thesis_transverse_shear_rows,
    transverse_shear_sensitivity,
)

__all__ = [
    "format_hollow",
    "run_hollow",
    "format_materials",
    "run_materials",
    "format_random",
    "run_random",
    "HIRES_RATES",
    "SCALE_LADDER",
    "SCALE_NAMED",
    "SCALE_RANDOM",
    "THESIS_IMPACTS",
    "THESIS_IMPEDANCE",
    "THESIS_RESTITUTION",
    "THESIS_TICK_DECAY",
    "ContactCase",
    "contact_cases",
    "envelope_decay_time",
    "format_analysis",
    "format_cold",
    "format_cost",
    "format_rules",
    "run_rules",
    "record_rates",
    "run_cost",
    "format_contact",
    "format_hires",
    "format_long",
    "format_modal_contact",
    "format_render",
    "format_rolling",
    "format_rolling_check",
    "format_scale",
    "format_surface_fit",
    "format_thesis",
    "hires_child",
    "long_child",
    "long_recording",
    "markdown_block",
    "modal_critical_distance",
    "random_scale_specs",
    "render_scenes",
    "run_analysis",
    "run_cold",
    "run_contact",
    "run_hires",
    "run_long",
    "run_modal_contact",
    "run_render",
    "run_rolling",
    "run_rolling_check",
    "run_scale",
    "scale_child",
    "scale_scene",
    "scipy_contact",
    "surface_fit",
    "synthetic_bounce",
    "thesis_comparison",
    "thesis_lowspeed_rows",
    "thesis_modal_rows",
    "thesis_row",
    "thesis_transverse_shear_rows",
    "transverse_shear_sensitivity",
]
