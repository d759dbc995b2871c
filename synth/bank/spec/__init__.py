"""Bank specs: a TOML file describing many variations of one preset, and their plan.

A spec (every key; only ``preset`` is required)::

    preset = "default"              # a preset name or a .toml file (relative to the spec)
    description = "..."             # text
    count = 200                     # random variations; leave out for the full grid of lists
    seed = 7                        # integer >= 0 for the draws (default 0)
    name = "{preset}-{index:04d}"   # file name template, without the suffix
    format = "flac"                 # "wav", "flac" (default) or "ogg" (Vorbis)
    sampling = "random"             # ranges: "random", "lhs" (Latin hypercube) or "grid"
    tags = ["impact", "glass"]      # free tags for every row: keywords, or a table of
                                    # name = text/number/boolean ({ category = "impact" })

    [vary]                          # axes: any preset key, dotted as in `synth render --set`
    "drop.height" = { min = 0.05, max = 0.3 }              # a range, drawn uniformly
    "drop.position" = { min = [0.2, 0.1], max = [1.0, 0.4] }  # vectors: per component
    "ball.radius" = [0.004, 0.005, 0.006]                   # a list: a grid axis
    "plate.thickness" = { min = 0.006, max = 0.018, log = true }  # log-uniform
    restitution_scale = [0.5, 1.0, 1.5]   # perception stimuli: 1 - e' = k (1 - e)

    [trim]                          # optional: cut the tails (see TRIM_DEFAULTS)
    below_db = -60.0

    [render]                        # overrides the preset's [render] (synth.render options)
    samplerate = 48000              # Hz
    normalize = "physical"          # "physical" (default for banks), "peak", "loudness", "none"
    max_impacts = 64                # the bounces end after this many impacts (bank default 64,
                                    # BANK_MAX_IMPACTS); bounce_floor_db = -60.0 their level rule
    subtype = "PCM_24"              # the files' sample format (soundfile subtype)

With ``count``, variation ``i`` draws its ranges from its own generator
``numpy.random.default_rng([seed, i])`` (uniformly or log-uniformly; with
``sampling = "lhs"`` within strata dealt block by block, :func:`_lhs_fraction`) and its
lists' combinations without replacement block by block (:class:`_ListDraws`), so a
variation does not depend on the count or on the rows after it: raising ``count`` adds
rows. A ``count`` above the distinct rows of a spec without ranges (its lists'
combinations) repeats them, with a :class:`RepeatedRowsWarning`.
Without ``count``, the plan is the grid of the list axes (the first axis varies
slowest) and the ranges are drawn per grid point the same way.

The name template is a Python format string over ``preset`` (the preset's name),
``index`` and the axes; ``/`` makes subfolders (``"h{drop.height:.2f}/{index:04d}"``; no
empty, hidden or ``..`` part, no absolute path). A dotted key is both ``{drop.height}``
and ``{drop_height}`` (``{drop.position[0]:.2f}`` for a vector's component). The suffix
comes from ``format``.

Every manifest row carries the spec's ``tags`` and its values' labels from ``[labels]``
(:func:`row_labels`). Neither they, the preset's name nor the name template change a
sound: a bank resumes across a change of them (:func:`compared_form`), its files taking
their new names.

``restitution_scale`` (dimensionless ``k >= 0``) is the bank's one key that is not a preset
key: the impacts are :func:`synth.stimuli.sequences.scaled_sequence` of the scene, as
``synth render --restitution-scale`` renders them (thesis section 5.2.2, see
docs/physics.md).

A spec that cannot be run is a :class:`BankSpecError` naming the key, its value and what is
allowed, raised before any work (the first scene is built too).

Modules: :mod:`~synth.bank.spec.model` (the record, its keys and forms),
:mod:`~synth.bank.spec.loading` (reading and checking a spec),
:mod:`~synth.bank.spec.sampling` (its variations), :mod:`~synth.bank.spec.naming` (labels
and file names) and :mod:`~synth.bank.spec.planning` (the plan).
"""

from __future__ import annotations

from synth.bank.spec.loading import PACKAGE_BANKS, available, find, from_dict, load
from synth.bank.spec.model import (
    BANK_MAX_IMPACTS,
    DEFAULT_NORMALIZE,
    ENGINE,
    FORMATS,
    MAX_ROWS,
    NOT_AUDIO,
    PLAN_VERSION,
    RENDER_DEFAULTS,
    RESTITUTION_SCALE,
    TOP_LEVEL,
    TRIM_DEFAULTS,
    BankSpec,
    BankSpecError,
    ListAxis,
    RangeAxis,
    canonical,
    compared_form,
)
from synth.bank.spec.naming import MAX_NAME_BYTES, file_name, row_labels
from synth.bank.spec.planning import (
    ROWS_NAMED,
    PlanItem,
    check_rows,
    differences,
    parse_rows,
    plan,
    row_problem,
    scene_data,
)
from synth.bank.spec.sampling import (
    LHS_BLOCK,
    MIN_DISTANCE_ATTEMPTS,
    MIN_DISTANCE_MAX_ROWS,
    PERMUTED_COMBINATIONS,
    SAMPLINGS,
    RepeatedRowsWarning,
    variations,
)

__all__ = [
    "BANK_MAX_IMPACTS",
    "BankSpec",
    "BankSpecError",
    "DEFAULT_NORMALIZE",
    "ENGINE",
    "FORMATS",
    "LHS_BLOCK",
    "ListAxis",
    "MAX_NAME_BYTES",
    "MAX_ROWS",
    "MIN_DISTANCE_ATTEMPTS",
    "MIN_DISTANCE_MAX_ROWS",
    "NOT_AUDIO",
    "PACKAGE_BANKS",
    "PERMUTED_COMBINATIONS",
    "PLAN_VERSION",
    "PlanItem",
    "RENDER_DEFAULTS",
    "RESTITUTION_SCALE",
    "ROWS_NAMED",
    "RangeAxis",
    "RepeatedRowsWarning",
    "SAMPLINGS",
    "TOP_LEVEL",
    "TRIM_DEFAULTS",
    "available",
    "canonical",
    "check_rows",
    "compared_form",
    "differences",
    "file_name",
    "find",
    "from_dict",
    "load",
    "parse_rows",
    "plan",
    "row_labels",
    "row_problem",
    "scene_data",
    "variations",
]
