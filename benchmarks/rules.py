"""``synth bench rules``: the radiation rule each scene takes and what each rule would cost.

For every shipped preset (at 48 kHz), the plates of ``synth bench scale`` (its ladder and its
random scenes) and the default board at the rates of ``synth bench hires``, the microphone's
radiation problem (:func:`synth.cost.radiation.radiation_problem`, nothing solved), the cost
of each rule that takes its shapes (:meth:`synth.sound.radiation.rules.Rule.cost`: the first
rule and its check rule in rectangle-term equivalents, over the shipped rectangle rate: the
estimated seconds on the machine that recorded the rates) and the rule
:func:`~synth.sound.radiation.rules.choose_rule` takes. A rule never chosen here is a rule
whose cost never pays on these scenes.
"""

from __future__ import annotations

from benchmarks.common import markdown_table

#: The rules' columns, in order (``-`` where a rule does not take the scene's shapes).
RULE_NAMES = ("rectangle", "polar", "summed", "banded", "boundary")


def _scenes() -> list:
    """(name, scene, samplerate Hz) of every scene of the table."""
    from benchmarks.hires import HIRES_RATES
    from benchmarks.scale import SCALE_LADDER, SCALE_RANDOM, random_scale_specs, scale_scene
    from synth.io import presets

    rows = [(name, presets.load_preset(name), 48000) for name in sorted(presets.available())]
    for name, material, h, a, b, boundary, fs in SCALE_LADDER:
        rows.append((f"scale: {name} {fs} Hz", scale_scene(material, h, a, b, boundary), fs))
    for i, spec in enumerate(random_scale_specs(SCALE_RANDOM)):
        scene = scale_scene(
            spec["material"], spec["thickness"], spec["length"], spec["width"], spec["boundary"]
        )
        rows.append((f"scale: random {i + 1}", scene, spec["samplerate"]))
    default = presets.load_preset("default")
    rows += [(f"default at {fs} Hz", default, fs) for fs in HIRES_RATES]
    return rows


def run_rules() -> list:
    """One row per scene with a microphone: its shapes, modes, each rule's estimated
    seconds (None where the rule does not apply) and the rule chosen."""
    from synth.cost import Rates
    from synth.cost.modal import modal_count
    from synth.cost.radiation import radiation_problem
    from synth.physics.scene import Microphone
    from synth.sound.radiation.rules import RULES, choose_rule

    rate = Rates.load().radiation["rectangle"]
    rows = []
    for name, scene, fs in _scenes():
        if not isinstance(scene.listener, Microphone):
            continue
        f_max = 0.5 * fs
        modes = modal_count(scene.plate, f_max)
        problem = radiation_problem(scene.plate, scene.listener, modes, f_max)
        costs = {r.name: r.cost(problem) / rate for r in RULES if r.applies(problem)}
        rows.append(
            {
                "scene": name,
                "shapes": problem.shapes,
                "modes": modes,
                "seconds": costs,
                "chosen": choose_rule(problem).name,
            }
        )
    return rows


def format_rules(rows) -> str:
    """The table of :func:`run_rules` and the count of scenes each rule is chosen for."""
    header = ["scene", "shapes", "modes", *RULE_NAMES, "chosen"]
    cells = [
        [row["scene"], row["shapes"], str(row["modes"])]
        + [f"{row['seconds'][n]:.3g}" if n in row["seconds"] else "-" for n in RULE_NAMES]
        + [row["chosen"]]
        for row in rows
    ]
    chosen = {n: sum(row["chosen"] == n for row in rows) for n in RULE_NAMES}
    lines = markdown_table(header, cells)
    lines += [
        "",
        "Estimated seconds of each rule's first rule and check rule (its cost in "
        "rectangle-term equivalents over the shipped rectangle rate, synth/cost_rates.json); "
        "'chosen' is choose_rule's pick. Scenes per rule: "
        + ", ".join(f"{n} {c}" for n, c in chosen.items())
        + ".",
    ]
    return "\n".join(lines)
