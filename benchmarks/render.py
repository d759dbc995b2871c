"""``synth bench render``: a render's error (against a tight reference render) against its
run time, per scene, floor and tolerance; and the rolling presets' real-time factors, measured
as ``synth bench rolling`` measures them (:func:`benchmarks.rolling.run_scenes`)."""

from __future__ import annotations

import math
import time

import numpy as np

from benchmarks.common import markdown_table, target_verdict
from benchmarks.rolling import format_scenes, run_scenes


def render_scenes() -> list:
    """The render benchmark's scenes: ``(name, scene, render options)``: the default
    preset (the measured model), and the same scene under the thesis' model beside it (the
    speed the measured model is held to, in the same run); the thesis' corner drop, where
    the plate's modes enter every contact; a thin steel sheet whose modal bank carries
    thousands of modes; a long series of fast small bounces."""
    from synth.io.presets import load_preset
    from synth.physics.scene import Accelerometer, Ball, Plate, Scene

    sheet = Plate("steel", 0.0005, 0.8, 0.6, "simply-supported")
    return [
        ("default preset (10 mm steel on 18 mm MDF, microphone)", load_preset("default"), {}),
        (
            "default preset, the thesis' model (contact.model = thesis)",
            load_preset("default", ["contact.model=thesis"]),
            {},
        ),
        (
            "thesis-steel10-mdf18-corner (the plate's modes in every contact)",
            load_preset("thesis-steel10-mdf18-corner"),
            {},
        ),
        (
            "steel sheet 0.5 mm, 0.8 x 0.6 m, 1 mm steel ball, accelerometer, 5 s of tail",
            Scene(
                Ball("steel", 0.001),
                sheet,
                drop_height=0.2,
                position=(0.336, 0.258),
                listener=Accelerometer((0.24, 0.36)),
            ),
            {"max_tail": 5.0},
        ),
        ("small-click-on-acrylic (fast small bounces)", load_preset("small-click-on-acrylic"), {}),
    ]


def _lsd(a, b, fs):
    """Log-spectral distance (dB) between two signals, Welch PSDs over the band where the
    reference has energy (within 100 dB of its maximum)."""
    from scipy.signal import welch

    n = min(a.size, b.size)
    f, pa = welch(a[:n], fs, nperseg=2048)
    _, pb = welch(b[:n], fs, nperseg=2048)
    band = pb > pb.max() * 1e-10
    return float(np.sqrt(np.mean((10 * np.log10((pa[band] + 1e-300) / pb[band])) ** 2)))


#: The renderer's targets at its default settings: error against the reference (dB, rel.
#: L2), real-time factor of the default preset (``realtime``, and the fixed costs' goal
#: ``realtime_goal``), the modal bank's cost, and the largest share of a render's time
#: outside the modal bank (its fixed costs: contacts, transforms, the rest).
RENDER_TARGETS = dict(
    error_db=-60.0,
    realtime=100.0,
    realtime_goal=1000.0,
    ns_per_mode_sample=1.0,
    non_bank_share=0.5,
)
#: ``synth render default`` as a whole process on warm caches (numba's and the plate
#: modes'): the command the CLI's time is measured on.
CLI_RENDER = (
    "from synth.cli import main\nraise SystemExit(main(['render', 'default', '-o', {path!r}]))\n"
)
#: The reference: no omission, a tight contact tolerance, a fine transform grid.
REFERENCE = dict(floor_db=-200.0, rtol=1e-10, pulse_points=1025)


#: Wait between the reference renders and the timed ones, s (see :func:`run_render`).
BLAS_SETTLE = 1.0


def _reference(scene, opts, samplerate, render):
    """The reference render of ``scene`` (:data:`REFERENCE`: no omission, a tight contact
    tolerance, a fine transform grid)."""
    import dataclasses

    ref_scene = dataclasses.replace(
        scene, contact=dataclasses.replace(scene.contact, rtol=REFERENCE["rtol"])
    )
    return render(
        ref_scene,
        samplerate=samplerate,
        normalize="none",
        fade=0.0,
        floor_db=REFERENCE["floor_db"],
        pulse_points=REFERENCE["pulse_points"],
        **opts,
    )


def _split(times, results) -> dict:
    """Where the renders' time went (s, medians): the modal bank, the contacts, the pulses'
    transforms and the rest (the level stage, gains, Python), and the share of the whole
    outside the bank."""
    total = float(np.median(times))
    parts = {
        name: float(np.median([r.settings[f"{name}_seconds"] for r in results]))
        for name in ("bank", "contact", "transform")
    }
    rest = total - sum(parts.values())
    return dict(
        bank_s=parts["bank"],
        contacts_s=parts["contact"],
        transforms_s=parts["transform"],
        rest_s=rest,
        non_bank_share=1.0 - parts["bank"] / total,
    )


def cli_render_time(runs: int = 5) -> dict:
    """``synth render default`` as a whole process with warm caches (numba's and the plate
    modes', the environment's): wall and CPU time (s, user + system), medians of ``runs``
    runs after one that fills the caches if they are not."""
    import os
    import tempfile

    from benchmarks.cold import run_child

    walls, cpus = [], []
    with tempfile.TemporaryDirectory(prefix="synth-cli-") as tmp:
        code = CLI_RENDER.format(path=os.path.join(tmp, "default.wav"))
        for i in range(runs + 1):
            cpu, wall, _, stderr, status = run_child(code, dict(os.environ))
            if status != 0:
                return dict(error=(stderr.strip().splitlines() or ["failed"])[-1])
            if i:
                walls.append(wall)
                cpus.append(cpu)
    return dict(runs=runs, wall_s=float(np.median(walls)), cpu_s=float(np.median(cpus)))


def run_render(
    floors=(-40.0, -60.0, -80.0, -100.0),
    tolerances=(1e-6, 1e-9),
    samplerate=48000,
    repeat: int = 5,
    cli_runs: int = 5,
) -> dict:
    """Error of the audio against a reference render against render time, the modal
    bank's cost per mode-sample and the real-time factor, on one thread.

    Parameters
    ----------
    floors : sequence of float < 0
        Omission floors (``render(floor_db=...)``), dB.
    tolerances : sequence of float
        Contact tolerances (``Contact.rtol``), dimensionless.
    samplerate : int
        Hz.
    repeat : int
        Timed renders per figure (the median is reported), after one warm-up render.
    cli_runs : int
        Timed runs of ``synth render default`` as a whole process (:func:`cli_render_time`;
        0: none).

    Returns
    -------
    dict
        ``rows``: per scene, tolerance and floor, the error (relative L2, and in dB),
        the log-spectral distance (dB), the render time (s, median), the real-time
        factor, the modes rendered and below Nyquist, the mode-samples and the bank's
        ns per mode-sample; ``default`` marks the engine's default settings (floor
        -80 dB, rtol 1e-9) and holds the split of its time (:func:`_split`); ``cli``:
        the whole-process time of ``synth render default``; ``summary``: the targets and
        whether they are met; ``rolling``: the rolling presets' renders and their
        real-time factors (:func:`benchmarks.rolling.run_scenes`, best of ``repeat``).

    Notes
    -----
    The reference renders each scene with no omission (floor -200 dB), contact rtol
    1e-10 and 1025 points per pulse for the transforms. The output stage's fade is off
    in every render compared (it is not an omission). numba runs on one thread.
    """
    import dataclasses

    import numba

    from synth.sound.render import render

    threads = numba.get_num_threads()
    numba.set_num_threads(1)
    rows = []
    try:
        scenes = render_scenes()
        references = [_reference(scene, opts, samplerate, render) for _, scene, opts in scenes]
        # the references' large complex products run on OpenBLAS's worker threads, which
        # spin for a while after their last product; on two cores they would take the
        # timed renders' core, so the timing starts once they have gone to sleep
        time.sleep(BLAS_SETTLE)
        for (name, scene, opts), ref in zip(scenes, references):
            ref_audio = ref.audio.astype(float)
            ref_norm = np.linalg.norm(ref_audio)
            for tol in tolerances:
                sc = dataclasses.replace(
                    scene, contact=dataclasses.replace(scene.contact, rtol=tol)
                )
                for floor in floors:
                    kw = dict(
                        samplerate=samplerate, normalize="none", floor_db=floor, fade=0.0, **opts
                    )
                    render(sc, **kw)  # warm-up
                    times, results = [], []
                    for _ in range(repeat):
                        t0 = time.perf_counter()
                        r = render(sc, **kw)
                        times.append(time.perf_counter() - t0)
                        results.append(r)
                    a = r.audio.astype(float)
                    n = max(a.size, ref_audio.size)
                    a = np.pad(a, (0, n - a.size))
                    b = np.pad(ref_audio, (0, n - ref_audio.size))
                    err = np.linalg.norm(a - b) / ref_norm
                    t = float(np.median(times))
                    ms = r.settings["mode_samples"]
                    split = _split(times, results)
                    rows.append(
                        dict(
                            scene=name,
                            rtol=tol,
                            floor_db=floor,
                            default=(floor == -80.0 and tol == 1e-9),
                            error_db=20 * math.log10(max(err, 1e-300)),
                            error=err,
                            lsd_db=_lsd(a, b, samplerate),
                            seconds=t,
                            realtime=r.duration / t,
                            duration=r.duration,
                            modes=r.settings["n_modes"],
                            modes_rendered=r.settings["n_modes_rendered"],
                            mode_samples=ms,
                            impacts=len(r.impacts),
                            ns_per_mode_sample=split["bank_s"] / max(ms, 1) * 1e9,
                            **split,
                        )
                    )
    finally:
        numba.set_num_threads(threads)
    cli = cli_render_time(cli_runs) if cli_runs > 0 else None
    return dict(
        samplerate=samplerate, reference=REFERENCE, rows=rows, cli=cli, summary=_summary(rows),
        rolling=run_scenes(repeat),
    )  # fmt: skip


def _summary(rows) -> dict:
    """The targets (:data:`RENDER_TARGETS`) at the default settings and whether they are
    met: the worst error, the default preset's real-time factor, the worst cost per
    mode-sample and the largest share outside the bank."""
    t = RENDER_TARGETS
    defaults = [r for r in rows if r["default"]]
    summary = dict(targets=t)
    if not defaults:
        return summary
    summary.update(
        worst_error_db=max(r["error_db"] for r in defaults),
        default_preset_realtime=defaults[0]["realtime"],
        worst_ns_per_mode_sample=max(r["ns_per_mode_sample"] for r in defaults),
        worst_non_bank_share=max(r["non_bank_share"] for r in defaults),
    )
    summary["met"] = dict(
        error_db=bool(summary["worst_error_db"] <= t["error_db"]),
        realtime=bool(summary["default_preset_realtime"] >= t["realtime"]),
        realtime_goal=bool(summary["default_preset_realtime"] >= t["realtime_goal"]),
        ns_per_mode_sample=bool(summary["worst_ns_per_mode_sample"] <= t["ns_per_mode_sample"]),
        non_bank_share=bool(summary["worst_non_bank_share"] <= t["non_bank_share"]),
    )
    return summary


def format_render(result) -> str:
    """The render benchmark as a Markdown table, with the targets and whether they are met."""
    ref = result["reference"]
    lines = [
        f"samplerate {result['samplerate']} Hz, one thread; reference: floor {ref['floor_db']:.0f} dB "
        f"(no omission), contact rtol {ref['rtol']:.0e}, {ref['pulse_points']} points per pulse; "
        "* = default settings",
        "| scene | rtol | floor (dB) | error re reference (dB, rel. L2) | log-spectral distance (dB) | "
        "render (ms) | real-time factor | modes rendered / below Nyquist | mode-samples | bank (ns per mode-sample) |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in result["rows"]:
        mark = " *" if r["default"] else ""
        lines.append(
            f"| {r['scene']} | {r['rtol']:.0e} | {r['floor_db']:.0f}{mark} | {r['error_db']:.1f} | "
            f"{r['lsd_db']:.3f} | {r['seconds'] * 1e3:.1f} | {r['realtime']:.0f}x | "
            f"{r['modes_rendered']} / {r['modes']} | {r['mode_samples']:.3g} | "
            f"{r['ns_per_mode_sample']:.2f} |"
        )
    lines += _split_table(result["rows"])
    if "rolling" in result:
        lines += ["", "The rolling presets, rendered whole (`synth bench rolling`'s table):", ""]
        lines.append(format_scenes(result["rolling"]))
    cli = result.get("cli")
    if cli is not None:
        lines += ["", _cli_line(cli)]
    s = result["summary"]
    if "met" in s:
        t = s["targets"]
        lines += [
            "",
            "Targets at the default settings:",
            f"- error against the reference, worst scene: {s['worst_error_db']:.1f} dB "
            f"(target <= {t['error_db']:.0f} dB): {target_verdict(s['met']['error_db'])}",
            f"- default preset: {s['default_preset_realtime']:.0f}x faster than real time "
            f"(target >= {t['realtime']:.0f}x): {target_verdict(s['met']['realtime'])}",
            f"- modal bank, worst scene: {s['worst_ns_per_mode_sample']:.2f} ns per mode-sample "
            f"(target <= {t['ns_per_mode_sample']:.0f} ns): {target_verdict(s['met']['ns_per_mode_sample'])}",
            f"- no preset's non-bank share above {t['non_bank_share']:.0%}: worst "
            f"{s['worst_non_bank_share']:.0%}: {target_verdict(s['met']['non_bank_share'])}",
            f"- default preset at least {t['realtime_goal']:.0f}x: "
            f"{s['default_preset_realtime']:.0f}x: {target_verdict(s['met']['realtime_goal'])}",
        ]
    return "\n".join(lines)


def _split_table(rows) -> list[str]:
    """Where each scene's render time goes at the default settings (``*``)."""
    head = [
        "",
        "Where a render's time goes at the default settings (medians, ms): the modal bank, "
        "the contacts (the bounce series), the pulses' transforms, the rest (cost estimate, "
        "modes and gains, level stage, Python), and the share outside the bank",
    ]
    cells = [
        [
            r["scene"],
            f"{r['seconds'] * 1e3:.2f}",
            f"{r['bank_s'] * 1e3:.2f}",
            f"{r['contacts_s'] * 1e3:.2f}",
            f"{r['transforms_s'] * 1e3:.2f}",
            f"{r['rest_s'] * 1e3:.2f}",
            f"{r['non_bank_share']:.0%}",
        ]
        for r in rows
        if r["default"]
    ]
    header = [
        "scene", "render (ms)", "bank (ms)", "contacts (ms)", "transforms (ms)", "rest (ms)",
        "non-bank share (% of render)",
    ]  # fmt: skip
    return head + markdown_table(header, cells)


def _cli_line(cli) -> str:
    """The whole-process time of ``synth render default``."""
    if "error" in cli:
        return f"`synth render default` as a whole process: failed ({cli['error']})"
    return (
        f"`synth render default` as a whole process, warm caches: {cli['wall_s']:.2f} s wall, "
        f"{cli['cpu_s']:.2f} s CPU (medians of {cli['runs']} runs)"
    )
