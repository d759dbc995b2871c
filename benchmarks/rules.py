"""``synth bench rules``: the radiation rule each scene takes and what each rule would cost.

For every shipped preset (at 48 kHz), the plates of ``synth bench scale`` (its ladder and its
random scenes) and the default board at the rates of ``synth bench hires``, the microphone's
radiation problem (:func:`synth.cost.estimates.radiation_problem`, nothing solved), the cost
of each rule that takes its shapes (:meth:`synth.sound.radiation.rules.Rule.cost`: the first
rule and its check rule in rectangle-term equivalents, over the shipped rectangle rate: the
estimated seconds on the machine that recorded the rates) and the rule
:func:`~synth.sound.radiation.rules.choose_rule` takes; per rule, the scenes it is chosen for
and its least cost ratio to the cheapest other rule (:func:`rule_summary`). A rule never
chosen here is a rule whose estimated cost never pays on these scenes. ``python -m
benchmarks.rules`` gives the same summary for the random scenes of
:mod:`benchmarks.analysis_scenes` (seeds 5000-5999, :func:`run_random_rules`).
"""

from __future__ import annotations

from benchmarks.common import markdown_table

#: The rules' columns, in order (``-`` where a rule does not take the scene's shapes).
RULE_NAMES = ("rectangle", "polar", "summed", "banded")


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


def _row(name, scene, fs, rate) -> dict | None:
    """One row of :func:`run_rules` for ``scene`` at ``fs`` Hz (``rate`` the shipped rectangle
    rate, terms per second), or None for an accelerometer."""
    from synth.cost import modal_count
    from synth.cost.estimates import radiation_problem
    from synth.physics.scene import Microphone
    from synth.sound.radiation.rules import RULES, choose_rule

    if not isinstance(scene.listener, Microphone):
        return None
    f_max = 0.5 * fs
    modes = modal_count(scene.plate, f_max)
    problem = radiation_problem(scene.plate, scene.listener, modes, f_max)
    return {
        "scene": name,
        "shapes": problem.shapes,
        "modes": modes,
        "seconds": {r.name: r.estimate(problem).cost / rate for r in RULES if r.applies(problem)},
        "chosen": choose_rule(problem).rule.name,
    }


def run_rules() -> dict:
    """``rows``, one per scene with a microphone: its shapes, modes, each rule's estimated
    seconds (absent where the rule does not apply) and the rule chosen."""
    from synth.cost import Rates

    rate = Rates.load().radiation["rectangle"]
    rows = [_row(name, scene, fs, rate) for name, scene, fs in _scenes()]
    return {"rows": [row for row in rows if row is not None]}


def run_random_rules(seeds=range(5000, 6000)) -> dict:
    """:func:`run_rules` for the random scenes of :mod:`benchmarks.analysis_scenes`, one a
    seed (those with a microphone), at their own sample rates."""
    from benchmarks.analysis_scenes import build_scene, random_specs
    from synth.cost import Rates

    rate = Rates.load().radiation["rectangle"]
    rows = []
    for seed in seeds:
        spec = random_specs(1, seed)[0]
        rows.append(_row(f"seed {seed}", build_scene(spec), spec.samplerate, rate))
    return {"rows": [row for row in rows if row is not None]}


def rule_summary(rows: list) -> list:
    """Per rule of :data:`RULE_NAMES`: the scenes it is chosen for and, over the scenes it
    takes, its least ratio of estimated cost to the cheapest other rule's (below 1 where it
    is chosen on cost), with the scene of that ratio."""
    out = []
    for name in RULE_NAMES:
        ratios = [
            (row["seconds"][name] / min(v for n, v in row["seconds"].items() if n != name), row)
            for row in rows
            if name in row["seconds"] and len(row["seconds"]) > 1
        ]
        best = min(ratios, key=lambda item: item[0], default=(None, None))
        out.append(
            {
                "rule": name,
                "chosen": [row["scene"] for row in rows if row["chosen"] == name],
                "best_ratio": best[0],
                "best_scene": None if best[1] is None else best[1]["scene"],
            }
        )
    return out


def _summary_lines(rows: list) -> list:
    """The lines of :func:`rule_summary`."""
    lines = [
        "Per rule: the scenes it is chosen for; its least cost ratio to the next cheapest.",
        "",
    ]
    for s in rule_summary(rows):
        scenes = ", ".join(s["chosen"]) if s["chosen"] else "none"
        ratio = "-" if s["best_ratio"] is None else f"{s['best_ratio']:.3g} ({s['best_scene']})"
        lines.append(f"- {s['rule']}: chosen for {len(s['chosen'])}: {scenes}; least ratio {ratio}")
    return lines


def format_rules(result) -> str:
    """The table of :func:`run_rules`, and the count and names of the scenes each rule is
    chosen for with its cost ratio to the next cheapest rule."""
    rows = result["rows"]
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
        "",
        *_summary_lines(rows),
    ]
    return "\n".join(lines)


if __name__ == "__main__":  # python -m benchmarks.rules: the random analysis scenes' choice
    rows = run_random_rules()["rows"]
    print(f"{len(rows)} random analysis scenes with a microphone (seeds 5000-5999)")
    for s in rule_summary(rows):
        ratio = "-" if s["best_ratio"] is None else f"{s['best_ratio']:.3g} ({s['best_scene']})"
        print(f"- {s['rule']}: chosen for {len(s['chosen'])}; least ratio {ratio}")
