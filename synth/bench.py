"""Benchmarks: numerical error against run time (``synth bench ...``).

Every figure is measured in one run on this machine, after a warm-up. Nothing
here is imported by the rest of the engine.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from synth.constants import GRAVITY
from synth.physics import contact, impedance
from synth.physics.scene import Ball, Plate


@dataclass(frozen=True)
class ContactCase:
    """A benchmark impact, in lumped parameters (SI)."""

    name: str
    mass: float  # kg
    stiffness: float  # N/m^n
    admittance: float  # m/(N s)
    speed: float  # m/s
    gravity: float  # m/s^2
    exponent: float = 1.5
    dissipation: float = 0.0  # s/m


def _case(name, ball, plate, speed, gravity=GRAVITY, contact_law="hertz", **kw):
    K, n, mu = contact.contact_law(ball, plate, contact_law, **kw)
    beta = 1.0 / impedance.infinite_plate_impedance(plate)
    return ContactCase(name, ball.mass, K, beta, speed, gravity, n, mu)


def contact_cases() -> list[ContactCase]:
    """The benchmark's impacts: steel on MDF, steel on a steel plate, a heavy ball on a thin
    plate (lam > 1), a gravity-dominated impact at 1 mm/s, plus a stiff and a lossy one."""
    steel10 = Ball("steel", 0.005)
    mdf18 = Plate("mdf-18", 0.018, 1.227, 0.49)
    return [
        _case("steel 10 mm on MDF 18 mm, 1 m/s", steel10, mdf18, 1.0),
        _case("steel 10 mm on steel 5 mm, 1 m/s", steel10, Plate("steel", 0.005, 1.0, 0.8), 1.0),
        _case(
            "steel 20 mm on aluminium 4 mm, 1 m/s (lam > 1)",
            Ball("steel", 0.01),
            Plate("aluminium", 0.004, 1.0, 0.8),
            1.0,
        ),
        _case("steel 10 mm on MDF 18 mm, 1 mm/s (gravity)", steel10, mdf18, 1e-3),
        _case(
            "steel 50 mm on aluminium 0.5 mm, 5 m/s (stiff, Radau)",
            Ball("steel", 0.025),
            Plate("aluminium", 0.0005, 1.0, 0.8),
            5.0,
        ),
        _case(
            "glass 12.55 mm on MDF 6 mm, Hunt-Crossley mu=0.2 s/m",
            Ball("glass", 0.006275),
            Plate("mdf-6", 0.00615, 1.2, 0.4895),
            1.4,
            contact_law="hunt-crossley",
            dissipation=0.2,
        ),
    ]


def _scaled(case):
    v0 = case.speed
    n = case.exponent
    theta = (case.mass / (case.stiffness * v0 ** (n - 1.0))) ** (1.0 / (n + 1.0))
    lam = case.admittance * case.mass / theta
    G = case.gravity * theta / v0
    return theta, lam, G, case.dissipation * v0


def scipy_contact(
    case: ContactCase, method: str = "Radau", rtol: float = 1e-12, atol: float = 1e-15
) -> tuple:
    """The same impact integrated by ``scipy.integrate.solve_ivp`` (an independent
    implementation of the same dimensionless equations), for reference and comparison.

    Returns (restitution, contact_time (s), sol (dense output in s, dimensionless), theta).
    """
    from scipy.integrate import solve_ivp

    theta, lam, G, c = _scaled(case)
    n = case.exponent

    def force(x, w):
        if x <= 0.0:
            return 0.0
        a = x**n
        if c == 0.0:
            return a
        return max(0.0, a * (1.0 + c * w) / (1.0 + c * lam * a))

    def rhs(s, y):
        f = force(y[0], y[1])
        return [y[1] - lam * f, G - f]

    def jac(s, y):
        x, w = y
        if x <= 0.0:
            return [[0.0, 1.0], [0.0, 0.0]]
        a = x**n
        da = n * a / x
        if c == 0.0:
            fx, fw = da, 0.0
        else:
            num, den = 1.0 + c * w, 1.0 + c * lam * a
            fx, fw = (da * num / den**2, a * c / den) if num > 0 else (0.0, 0.0)
        return [[-lam * fx, 1.0 - lam * fw], [-fx, -fw]]

    def end(s, y):
        return y[0]

    end.terminal = True
    end.direction = -1

    def settle(s, y):
        x, w = y
        u = lam * G - w
        W = 0.5 * u * u + (x ** (n + 1) / (n + 1) - G * x if x > 0 else 0.0)
        return W - 0.5 * (lam * G) ** 2

    settle.terminal = True
    settle.direction = -1

    events = [end, settle] if (G > 0 and lam > 0) else [end]
    kw = dict(jac=jac) if method in ("Radau", "BDF", "LSODA") else {}
    # start a hair after first touch so that the x = 0 event does not fire at s = 0
    # (with the first terms of the series solution there: x = s + G s^2/2, w = 1 + G s)
    s0 = 1e-10
    y0 = [s0 + 0.5 * G * s0 * s0, 1.0 + G * s0]
    sol = solve_ivp(
        rhs,
        (s0, 1e9),
        y0,
        method=method,
        rtol=rtol,
        atol=atol,
        events=events,
        dense_output=True,
        **kw,
    )
    if sol.t_events[0].size:
        s_end = sol.t_events[0][0]
        w_end = sol.y_events[0][0][1]
        e = max(0.0, -w_end)
    else:
        s_end = sol.t_events[1][0] if len(sol.t_events) > 1 and sol.t_events[1].size else sol.t[-1]
        e = 0.0
    return e, s_end * theta, sol, theta


def _median_time(fn, repeat):
    ts = np.empty(repeat)
    for i in range(repeat):
        t0 = time.perf_counter()
        fn()
        ts[i] = time.perf_counter() - t0
    return float(np.median(ts))


def _pulse_error(res, sol, theta, case):
    """Relative L2 error of the force pulse against the reference's dense output."""
    _, lam, G, c = _scaled(case)
    n = case.exponent
    s = res.time / theta
    y = sol.sol(np.clip(s, sol.t[0], sol.t[-1]))
    x = np.maximum(y[0], 0.0)
    a = x**n
    if c == 0.0:
        f = a
    else:
        f = np.maximum(0.0, a * (1.0 + c * y[1]) / (1.0 + c * lam * a))
    f_ref = f * case.mass * case.speed / theta
    return float(np.linalg.norm(res.force - f_ref) / np.linalg.norm(f_ref))


#: The contact solver's targets at the default rtol: the restitution error, the
#: median time of one impact (us), and the speed-up over scipy's solve_ivp at equal error.
CONTACT_TARGETS = dict(err_restitution=1e-6, us_per_impact=20.0, speedup=100.0)
DEFAULT_RTOL = 1e-6


def _finite_or_none(x):
    return None if x is None or not math.isfinite(x) else x


def run_contact(
    tolerances=(1e-3, 1e-4, 1e-6, 1e-8, 1e-10),
    repeat: int = 300,
    cases=None,
    *,
    modal: bool = False,
) -> dict:
    """Error of e, tau and the pulse against the reference, and time per impact.

    Returns a dict with ``rows`` (one per case and tolerance; the default rtol 1e-6 is
    always measured), ``scipy`` (for each case: our time at the default rtol, scipy
    DOP853's time at matched error, ratio), ``gravity`` (for each case: the time with
    and without gravity and the change of e that gravity makes) and ``summary`` (the
    targets and the figures that meet them or not). Errors are None where undefined.
    With ``modal``, ``modal`` holds :func:`run_modal_contact`'s rows (the plate's modes in
    the contact against the impedance model).
    """
    tolerances = tuple(sorted(set(float(t) for t in tolerances) | {DEFAULT_RTOL}, reverse=True))
    cases = contact_cases() if cases is None else list(cases)
    rows = []
    comparisons = []
    gravity_rows = []
    # warm up the kernels (compilation is cached on disk, but the first call loads it)
    for meth in ("DOP853", "Radau"):
        contact.solve_contact(mass=1e-3, stiffness=1e9, admittance=1e-3, speed=1.0, method=meth)
    for case in cases:
        e_ref, tau_ref, sol, theta = scipy_contact(case)
        kw = dict(
            mass=case.mass,
            stiffness=case.stiffness,
            admittance=case.admittance,
            speed=case.speed,
            gravity=case.gravity,
            exponent=case.exponent,
            dissipation=case.dissipation,
        )
        ours_default = None
        for tol in tolerances:
            res = contact.solve_contact(rtol=tol, **kw)
            t = _median_time(lambda: contact.solve_contact(rtol=tol, **kw), repeat)
            err_e = (
                abs(res.restitution - e_ref) / max(e_ref, 1e-300)
                if e_ref > 0
                else abs(res.restitution)
            )
            row = dict(
                case=case.name,
                rtol=tol,
                restitution=res.restitution,
                inelasticity=res.inelasticity,
                settled=bool(res.settled),
                err_restitution=err_e,
                err_contact_time=abs(res.contact_time - tau_ref) / tau_ref,
                err_pulse=_pulse_error(res, sol, theta, case),
                energy_residual=res.energy_residual,
                steps=res.n_steps,
                method=res.method,
                us_per_impact=t * 1e6,
            )
            rows.append(row)
            if tol == DEFAULT_RTOL:
                ours_default = row
        # scipy DOP853 at matched error: the loosest rtol whose errors are no larger
        target = max(ours_default["err_restitution"], ours_default["err_contact_time"], 1e-13)
        match = None
        for srtol in (1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-11, 1e-12, 1e-13):
            e_s, tau_s, _, _ = scipy_contact(case, "DOP853", rtol=srtol, atol=srtol * 1e-6)
            err = max(
                abs(e_s - e_ref) / max(e_ref, 1e-300) if e_ref > 0 else abs(e_s),
                abs(tau_s - tau_ref) / tau_ref,
            )
            if err <= target:
                match = (srtol, err)
                break
        srtol, err = match if match is not None else (1e-13, None)
        reps = max(3, repeat // 30)
        t_s = _median_time(
            lambda: scipy_contact(case, "DOP853", rtol=srtol, atol=srtol * 1e-6), reps
        )
        comparisons.append(
            dict(
                case=case.name,
                ours_us=ours_default["us_per_impact"],
                ours_error=target,
                scipy_rtol=srtol,
                scipy_error=err,
                matched=match is not None,
                scipy_us=t_s * 1e6,
                speedup=t_s * 1e6 / ours_default["us_per_impact"],
            )
        )
        # gravity: what it changes and what it costs (the solver always includes it)
        kw0 = dict(kw, gravity=0.0)
        res0 = contact.solve_contact(rtol=DEFAULT_RTOL, **kw0)
        t0 = _median_time(lambda: contact.solve_contact(rtol=DEFAULT_RTOL, **kw0), repeat)
        t1 = _median_time(lambda: contact.solve_contact(rtol=DEFAULT_RTOL, **kw), repeat)
        _, lam, G, _ = _scaled(case)
        gravity_rows.append(
            dict(
                case=case.name,
                g_theta_over_v=G,
                e_with=ours_default["restitution"],
                e_without=res0.restitution,
                change=abs(ours_default["restitution"] - res0.restitution),
                us_with=t1 * 1e6,
                us_without=t0 * 1e6,
            )
        )
    at_default = [r for r in rows if r["rtol"] == DEFAULT_RTOL]
    summary = dict(
        rtol=DEFAULT_RTOL,
        targets=CONTACT_TARGETS,
        max_err_restitution=max(r["err_restitution"] for r in at_default),
        median_us_per_impact=float(np.median([r["us_per_impact"] for r in at_default])),
        max_us_per_impact=max(r["us_per_impact"] for r in at_default),
        min_speedup=min(c["speedup"] for c in comparisons),
    )
    summary["met"] = dict(
        err_restitution=bool(summary["max_err_restitution"] <= CONTACT_TARGETS["err_restitution"]),
        us_per_impact=bool(summary["median_us_per_impact"] <= CONTACT_TARGETS["us_per_impact"]),
        speedup=bool(summary["min_speedup"] >= CONTACT_TARGETS["speedup"]),
    )
    for c in comparisons:
        c["scipy_error"] = _finite_or_none(c["scipy_error"])
    out = dict(rows=rows, scipy=comparisons, gravity=gravity_rows, summary=summary)
    if modal:
        out["modal"] = run_modal_contact(repeat=max(3, repeat // 15))
    return out


def format_contact(result) -> str:
    """The contact benchmark as Markdown tables, with the targets and whether they are met."""
    lines = [
        "| case | rtol | e | lambda | err e | err tau | err pulse (L2) | energy residual | steps | method | us/impact |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in result["rows"]:
        e = "settled" if r["settled"] else f"{r['restitution']:.6f}"
        lines.append(
            f"| {r['case']} | {r['rtol']:.0e} | {e} | {r['inelasticity']:.3g} | {r['err_restitution']:.1e} | "
            f"{r['err_contact_time']:.1e} | {r['err_pulse']:.1e} | {r['energy_residual']:.1e} | "
            f"{r['steps']} | {r['method']} | {r['us_per_impact']:.1f} |"
        )
    lines += [
        "",
        "| case | ours at rtol 1e-6 (us) | its error | solve_ivp DOP853 rtol at matched error | its error | solve_ivp (us) | speed-up |",
        "|---|---|---|---|---|---|---|",
    ]
    for c in result["scipy"]:
        err = "not reached" if c["scipy_error"] is None else f"{c['scipy_error']:.1e}"
        lines.append(
            f"| {c['case']} | {c['ours_us']:.1f} | {c['ours_error']:.1e} | {c['scipy_rtol']:.0e} | "
            f"{err} | {c['scipy_us']:.0f} | {c['speedup']:.0f}x |"
        )
    lines += [
        "",
        "Gravity during the contact (always integrated): its effect on e and its cost, rtol 1e-6",
        "| case | g theta / v | e with gravity | e without | change of e | us with | us without |",
        "|---|---|---|---|---|---|---|",
    ]
    for g in result["gravity"]:
        lines.append(
            f"| {g['case']} | {g['g_theta_over_v']:.2e} | {g['e_with']:.6f} | {g['e_without']:.6f} | "
            f"{g['change']:.1e} | {g['us_with']:.1f} | {g['us_without']:.1f} |"
        )
    s = result["summary"]
    t = s["targets"]
    ok = {True: "met", False: "NOT met"}
    lines += [
        "",
        f"Targets at rtol {s['rtol']:.0e}:",
        f"- restitution error, worst case: {s['max_err_restitution']:.1e} (target <= {t['err_restitution']:.0e}): "
        f"{ok[s['met']['err_restitution']]}",
        f"- time per impact, median over the cases: {s['median_us_per_impact']:.1f} us "
        f"(target <= {t['us_per_impact']:.0f} us; slowest case {s['max_us_per_impact']:.1f} us): "
        f"{ok[s['met']['us_per_impact']]}",
        f"- speed-up over solve_ivp (DOP853) at matched error, smallest: {s['min_speedup']:.0f}x "
        f"(target >= {t['speedup']:.0f}x): {ok[s['met']['speedup']]}",
    ]
    if "modal" in result:
        lines += ["", format_modal_contact(result["modal"])]
    return "\n".join(lines)


#: The modal contact's cases: 10 mm steel on the 18 mm board at 1.4 m/s (thesis Table 3.3),
#: at points from the middle to a corner (m from the board's corner).
MODAL_CONTACT_POINTS = {
    "middle": (0.6135, 0.245),
    "20 mm from an edge": (0.6135, 0.02),
    "edge": (0.6135, 0.0),
    "corner": (0.0, 0.0),
}
#: Band limits (units of 1 / tau) and steps per contact of the modal contact's ladder.
MODAL_BANDS = (2.0, 4.0, 8.0)
MODAL_STEPS = (128, 512, 2048)


def run_modal_contact(repeat: int = 20, points=None) -> list:
    """Error against run time of the two plates in the contact, 10 mm steel on 18 mm MDF at
    1.4 m/s: the impedance model (infinite plate, blended towards Eichler's edge and the
    measured corner near free edges) and the modal plate (``MODAL_BANDS`` x ``MODAL_STEPS``).

    The reference at each point is the modal plate at the widest band and 8192 steps, its
    band error removed by Richardson extrapolation over the two widest bands (the residual's
    error falls as ``Omega^-2``, tests/test_modal_contact.py). Times are medians of
    ``repeat`` solves of a contact built once (the build, modes from the cache and shapes at
    the point, is timed apart)."""
    from synth.physics import modal_contact as mc
    from synth.physics.contact import solve_impact

    ball, plate = _thesis_pair("steel 10.0 mm", "18 mm")
    v = math.sqrt(2.0 * GRAVITY * 0.1)
    tau = solve_impact(ball, plate, v, rtol=1e-9).contact_time
    chosen = (
        MODAL_CONTACT_POINTS if points is None else {k: MODAL_CONTACT_POINTS[k] for k in points}
    )
    rows = []
    for name, pos in chosen.items():

        def modal(band, steps):
            t0 = time.perf_counter()
            c = mc.ModalContact.for_pair(
                ball, plate, pos, max_frequency=band / tau, steps_per_contact=steps
            )
            build = time.perf_counter() - t0
            return c, build

        wide, narrow = MODAL_BANDS[-1], MODAL_BANDS[-2]
        e_w = modal(wide, 8192)[0].solve(v).restitution
        e_n = modal(narrow, 8192)[0].solve(v).restitution
        ref = e_w + (e_w - e_n) / ((wide / narrow) ** 2 - 1.0)
        imp = solve_impact(ball, plate, v, position=pos, rtol=1e-6)
        t_imp = _median_time(lambda: solve_impact(ball, plate, v, position=pos), repeat)
        rows.append(
            dict(
                point=name,
                model="impedance",
                band=None,
                steps=None,
                modes=0,
                restitution=imp.restitution,
                error=abs(imp.restitution - ref),
                us_per_impact=t_imp * 1e6,
                build_ms=0.0,
            )
        )
        for band in MODAL_BANDS:
            for steps in MODAL_STEPS:
                c, build = modal(band, steps)
                r = c.solve(v)
                t = _median_time(lambda: c.solve(v), repeat)
                rows.append(
                    dict(
                        point=name,
                        model="modal",
                        band=band,
                        steps=steps,
                        modes=int(c.point.omega.size),
                        restitution=r.restitution,
                        error=abs(r.restitution - ref),
                        us_per_impact=t * 1e6,
                        build_ms=build * 1e3,
                    )
                )
    return rows


def format_modal_contact(rows) -> str:
    """The table of :func:`run_modal_contact` (Markdown)."""
    lines = [
        "Plate in the contact, 10 mm steel on 18 mm MDF at 1.4 m/s: error of e against the "
        "converged modal plate, and time per impact",
        "| point | plate | band (1/tau) | steps | modes | e | error of e | us/impact | build (ms) |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        band = "-" if r["band"] is None else f"{r['band']:g}"
        steps = "-" if r["steps"] is None else str(r["steps"])
        lines.append(
            f"| {r['point']} | {r['model']} | {band} | {steps} | {r['modes']} | "
            f"{r['restitution']:.5f} | {r['error']:.1e} | {r['us_per_impact']:.0f} | "
            f"{r['build_ms']:.0f} |"
        )
    return "\n".join(lines)


if __name__ == "__main__":  # pragma: no cover
    print(format_contact(run_contact(repeat=100)))


# ---------------------------------------------------------------------------------------
# Rendering
# ---------------------------------------------------------------------------------------
def render_scenes() -> list:
    """The render benchmark's scenes: ``(name, scene, render options)``: the default
    preset; a thin steel sheet whose modal bank carries thousands of modes; a long series
    of fast small bounces."""
    from synth.io.presets import load_preset
    from synth.physics.scene import Accelerometer, Ball, Plate, Scene

    sheet = Plate("steel", 0.0005, 0.8, 0.6, "simply-supported")
    return [
        ("default preset (10 mm steel on 18 mm MDF, microphone)", load_preset("default"), {}),
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
#: L2), real-time factor of the default preset, and the modal bank's cost.
RENDER_TARGETS = dict(error_db=-60.0, realtime=100.0, ns_per_mode_sample=1.0)
#: The reference: no omission, a tight contact tolerance, a fine transform grid.
REFERENCE = dict(floor_db=-200.0, rtol=1e-10, pulse_points=1025)


def run_render(
    floors=(-40.0, -60.0, -80.0, -100.0), tolerances=(1e-6, 1e-9), samplerate=48000, repeat: int = 5
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

    Returns
    -------
    dict
        ``rows``: per scene, tolerance and floor, the error (relative L2, and in dB),
        the log-spectral distance (dB), the render time (s, median), the real-time
        factor, the modes rendered and below Nyquist, the mode-samples and the bank's
        ns per mode-sample; ``default`` marks the engine's default settings (floor
        -80 dB, rtol 1e-9); ``summary``: the targets and whether they are met.

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
        for name, scene, opts in render_scenes():
            ref_scene = dataclasses.replace(
                scene, contact=dataclasses.replace(scene.contact, rtol=REFERENCE["rtol"])
            )
            ref = render(
                ref_scene,
                samplerate=samplerate,
                normalize="none",
                fade=0.0,
                floor_db=REFERENCE["floor_db"],
                pulse_points=REFERENCE["pulse_points"],
                **opts,
            )
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
                    times, banks = [], []
                    for _ in range(repeat):
                        t0 = time.perf_counter()
                        r = render(sc, **kw)
                        times.append(time.perf_counter() - t0)
                        banks.append(r.settings["bank_seconds"])
                    a = r.audio.astype(float)
                    n = max(a.size, ref_audio.size)
                    a = np.pad(a, (0, n - a.size))
                    b = np.pad(ref_audio, (0, n - ref_audio.size))
                    err = np.linalg.norm(a - b) / ref_norm
                    t = float(np.median(times))
                    ms = r.settings["mode_samples"]
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
                            ns_per_mode_sample=float(np.median(banks)) / max(ms, 1) * 1e9,
                        )
                    )
    finally:
        numba.set_num_threads(threads)
    defaults = [r for r in rows if r["default"]]
    first = defaults[0] if defaults else None
    summary = dict(targets=RENDER_TARGETS)
    if defaults:
        summary.update(
            worst_error_db=max(r["error_db"] for r in defaults),
            default_preset_realtime=first["realtime"],
            worst_ns_per_mode_sample=max(r["ns_per_mode_sample"] for r in defaults),
        )
        summary["met"] = dict(
            error_db=bool(summary["worst_error_db"] <= RENDER_TARGETS["error_db"]),
            realtime=bool(summary["default_preset_realtime"] >= RENDER_TARGETS["realtime"]),
            ns_per_mode_sample=bool(
                summary["worst_ns_per_mode_sample"] <= RENDER_TARGETS["ns_per_mode_sample"]
            ),
        )
    return dict(samplerate=samplerate, reference=REFERENCE, rows=rows, summary=summary)


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
    s = result["summary"]
    if "met" in s:
        t = s["targets"]
        ok = {True: "met", False: "NOT met"}
        lines += [
            "",
            "Targets at the default settings:",
            f"- error against the reference, worst scene: {s['worst_error_db']:.1f} dB "
            f"(target <= {t['error_db']:.0f} dB): {ok[s['met']['error_db']]}",
            f"- default preset: {s['default_preset_realtime']:.0f}x faster than real time "
            f"(target >= {t['realtime']:.0f}x): {ok[s['met']['realtime']]}",
            f"- modal bank, worst scene: {s['worst_ns_per_mode_sample']:.2f} ns per mode-sample "
            f"(target <= {t['ns_per_mode_sample']:.0f} ns): {ok[s['met']['ns_per_mode_sample']]}",
        ]
    return "\n".join(lines)


# ---------------------------------------------------------------------------------------
# The thesis' measurements
# ---------------------------------------------------------------------------------------
def _decay_time(x, fs, smooth=0.5e-3):
    """Time (s) for the amplitude envelope (Hilbert, smoothed over ``smooth`` s) to fall
    from its peak to 1/e (37 %) of it."""
    from scipy.signal import hilbert

    env = np.abs(hilbert(x))
    n = max(1, int(smooth * fs))
    env = np.convolve(env, np.ones(n) / n, mode="same")
    i = int(np.argmax(env))
    below = np.nonzero(env[i:] < env[i] / math.e)[0]
    return float(below[0] / fs) if below.size else float("nan")


def _edc_decay_time(x, fs, lo_db=-5.0, hi_db=-25.0):
    """Decay time (s, amplitude to 1/e, i.e. 8.69 dB) from the slope of the Schroeder
    energy decay curve fitted between ``lo_db`` and ``hi_db``."""
    edc = np.cumsum((x**2)[::-1])[::-1]
    edc_db = 10 * np.log10(edc / edc[0] + 1e-300)
    sel = (edc_db <= lo_db) & (edc_db >= hi_db)
    if sel.sum() < 10:
        return float("nan")
    t = np.nonzero(sel)[0] / fs
    slope = np.polyfit(t, edc_db[sel], 1)[0]  # dB/s, negative
    return float(-20 * math.log10(math.e) / slope)


#: The thesis' balls (Table 3.1): name, material, diameter (m), weighed mass (kg).
THESIS_BALLS = {
    "steel 10.0 mm": ("steel", 10.00e-3, 4.17e-3),
    "steel 14.3 mm": ("steel", 14.30e-3, 11.83e-3),
    "steel 19.0 mm": ("steel", 19.00e-3, 28.07e-3),
    "glass 12.55 mm": ("glass", 12.55e-3, 2.57e-3),
    "glass 17.0 mm": ("glass", 17.00e-3, 6.39e-3),
}
#: The thesis' MDF boards (Table 3.1): name, material, thickness, length, width (m), and the
#: wave speed measured between two accelerometers 1 m apart (m/s, Chapter 3).
THESIS_BOARDS = {
    "18 mm": ("mdf-18", 0.018, 1.227, 0.49, 357.0),
    "12 mm": ("mdf-12", 0.012, 1.226, 0.4885, 282.0),
    "6 mm": ("mdf-6", 0.00615, 1.200, 0.4895, 159.0),
}
#: First impacts of Table 3.3 (drop 10 cm, middle of the board): (ball, board) -> measured
#: contact time (s), the ratio measured / model contact time of Table 3.2, and the measured
#: critical distance from a free edge inside which e falls (m, range).
THESIS_IMPACTS = {
    ("steel 10.0 mm", "18 mm"): (219e-6, 2.19, (35e-3, 45e-3)),
    ("steel 10.0 mm", "12 mm"): (229e-6, 2.43, (25e-3, 30e-3)),
    ("steel 10.0 mm", "6 mm"): (313e-6, 2.52, (25e-3, 35e-3)),
    ("steel 14.3 mm", "18 mm"): (266e-6, 1.85, (45e-3, 50e-3)),
    ("steel 19.0 mm", "18 mm"): (354e-6, 1.76, (55e-3, 60e-3)),
    ("glass 12.55 mm", "18 mm"): (208e-6, 2.57, (28e-3, 30e-3)),
    ("glass 17.0 mm", "18 mm"): (224e-6, 2.00, (40e-3, 45e-3)),
    ("glass 17.0 mm", "12 mm"): (234e-6, 2.25, (30e-3, 35e-3)),
    ("glass 17.0 mm", "6 mm"): (318e-6, 2.63, (20e-3, 30e-3)),
}
#: Restitution of the first impact, 10 mm steel on 18 mm MDF at 1.4 m/s: the thesis' model
#: and its measurement (Chapter 3, sections 3.2 and 3.5).
THESIS_RESTITUTION = {"model": 0.87, "measured": 0.76}
#: Driving-point impedance of the 18 mm board (Table 3.4, N s/m): the thesis' theory (the
#: infinite plate; Eichler's 0.29 of it at an edge; no theory at a corner) and the impact
#: hammer's measurement.
THESIS_IMPEDANCE = {
    "middle": (1629.0, 1271.0),
    "edge": (0.29 * 1629.0, 389.0),
    "corner": (None, 168.0),
}
#: Decay time (envelope from its peak to 37 %) of ticks 1, 6 and 8 at the microphone 20 cm
#: from the impact point, 10 mm steel ball, 18 mm board, 10 cm drop (Chapter 5, s).
THESIS_TICK_DECAY = {1: 11.0e-3, 6: 12.3e-3, 8: 14.0e-3}


def _thesis_pair(ball_name, board_name):
    from synth.physics.scene import Ball, Plate

    material, diameter, mass = THESIS_BALLS[ball_name]
    plate_material, h, a, b, _ = THESIS_BOARDS[board_name]
    return Ball(material, 0.5 * diameter, mass), Plate(plate_material, h, a, b)


def _tick_decay_times(scene, seq, ticks, samplerate):
    """Envelope decay time (s, peak to 37 %) of each tick in ``ticks`` (1-based) of ``seq``,
    each rendered alone (the ticks before it left out) at the scene's microphone."""
    from synth.physics.bounces import BounceSequence
    from synth.sound.render import render

    out = {}
    for n in ticks:
        alone = BounceSequence(seq.impacts[n - 1 : n], "max-impacts", seq.drop_height, seq.gravity)
        r = render(scene, samplerate=samplerate, normalize="none", sequence=alone)
        out[n] = _decay_time(r.audio.astype(float), r.samplerate)
    return out


def thesis_row(
    quantity: str,
    unit: str,
    engine: float,
    model: float | None,
    measured: float | tuple[float, float] | None,
    note: str = "",
) -> dict:
    """One row of the thesis comparison: the engine's value, the thesis' model value (None:
    the thesis has none), its measurement (a value, a (low, high) range or None) and the
    engine's gap to the measurement (engine minus the nearest end of a range; 0 inside)."""
    if measured is None:
        gap = None
    elif isinstance(measured, tuple):
        lo, hi = measured
        gap = 0.0 if lo <= engine <= hi else (engine - lo if engine < lo else engine - hi)
    else:
        gap = engine - measured
    rel = None if gap is None or isinstance(measured, tuple) else gap / measured
    return dict(
        quantity=quantity,
        unit=unit,
        engine=engine,
        model=model,
        measured=list(measured) if isinstance(measured, tuple) else measured,
        gap=gap,
        relative_gap=rel,
        note=note,
    )


def thesis_comparison(samplerate: int = 48000, *, modal: bool = False) -> dict:
    """The engine against the thesis' model and the thesis' measurements (Chapters 3 and 5),
    for every quantity the thesis measured (docs/validation.md, "Against the thesis'
    recordings"):

    * restitution of the first impact, 10 mm steel on 18 mm MDF, 1.4 m/s, middle;
    * contact time of the first impact of the nine ball/board pairs of Table 3.3 (model:
      the measurement over the ratio of Table 3.2);
    * critical distance from a free edge of the same pairs (engine: the distance at which
      the edge admittance starts to rise for the middle contact time; thesis prediction
      ``tau c / 2`` from its measured contact time and wave speed);
    * impedance of the 18 mm board at the middle, an edge and a corner (Table 3.4);
    * decay time of ticks 1, 6 and 8 at the microphone 20 cm away (envelope from its peak
      to 37 %), each tick rendered alone;
    * and, for the first tick, the spectral centroid, the 2-3 kHz decay time from the
      energy decay curve (the quantity the MDF damping law was fitted to) and the peak
      pressure, which have no measured counterpart.

    With ``modal``, the rows of :func:`thesis_modal_rows` follow (the finite plate in the
    contact; minutes on a cold cache of plate modes), and ``surface`` holds
    :func:`surface_fit` (MDF's contact surface fitted on the 18 mm board, its predictions).

    Returns a dict: ``rows`` (quantity, unit, engine, model, measured, gap, relative_gap,
    note; SI units, None where a value does not exist) and ``first_tick`` (figures of the
    first tick alone).
    """
    from scipy.signal import butter, sosfiltfilt

    from synth.io.presets import load_preset
    from synth.physics.bounces import BounceSequence, simulate_scene
    from synth.physics.contact import solve_impact
    from synth.sound.render import render

    rows = []
    ball, plate = _thesis_pair("steel 10.0 mm", "18 mm")
    first = solve_impact(ball, plate, math.sqrt(2.0 * GRAVITY * 0.1), rtol=1e-9)
    rows.append(
        thesis_row(
            "restitution, steel 10.0 mm on 18 mm, first impact (1.4 m/s)",
            "",
            first.restitution,
            THESIS_RESTITUTION["model"],
            THESIS_RESTITUTION["measured"],
        )
    )
    impacts = {}
    for (ball_name, board_name), (tau_meas, ratio, _) in THESIS_IMPACTS.items():
        ball, plate = _thesis_pair(ball_name, board_name)
        r = solve_impact(ball, plate, math.sqrt(2.0 * GRAVITY * 0.1), rtol=1e-9)
        impacts[ball_name, board_name] = (plate, r.contact_time)
        rows.append(
            thesis_row(
                f"contact time, {ball_name} on {board_name}",
                "s",
                r.contact_time,
                tau_meas / ratio,
                tau_meas,
                "model: Table 3.3 over Table 3.2's ratio",
            )
        )
    for (ball_name, board_name), (tau_meas, _, dc_meas) in THESIS_IMPACTS.items():
        plate, tau = impacts[ball_name, board_name]
        wave_speed = THESIS_BOARDS[board_name][4]
        rows.append(
            thesis_row(
                f"critical distance, {ball_name} on {board_name}",
                "m",
                impedance.critical_distance(plate, tau),
                0.5 * tau_meas * wave_speed,
                dc_meas,
                "model: the thesis' tau c / 2 from its measured tau and c",
            )
        )
    _, plate = _thesis_pair("steel 10.0 mm", "18 mm")
    z_inf = impedance.infinite_plate_impedance(plate)
    engine_z = {
        "middle": z_inf,
        "edge": impedance.edge_impedance(plate),
        "corner": impedance.corner_impedance(plate),
    }
    for where, (model, measured) in THESIS_IMPEDANCE.items():
        note = (
            "engine: Z_inf times the measured middle/corner ratio of the 18 and 12 mm boards"
            if where == "corner"
            else ""
        )
        rows.append(
            thesis_row(
                f"impedance, 18 mm, {where}", "N s/m", engine_z[where], model, measured, note
            )
        )

    scene = load_preset("default")
    seq = simulate_scene(scene)
    decays = _tick_decay_times(scene, seq, sorted(THESIS_TICK_DECAY), samplerate)
    for n, measured in THESIS_TICK_DECAY.items():
        rows.append(
            thesis_row(
                f"tick {n} decay at 20 cm, envelope peak to 37 %",
                "s",
                decays[n],
                None,
                measured,
                "the thesis has no model of the sound",
            )
        )

    alone = BounceSequence(seq.impacts[:1], "max-impacts", seq.drop_height, seq.gravity)
    r = render(scene, samplerate=samplerate, normalize="none", sequence=alone)
    x = r.audio.astype(float)
    fs = r.samplerate
    spec = np.abs(np.fft.rfft(x)) ** 2
    f = np.fft.rfftfreq(x.size, 1 / fs)
    band = sosfiltfilt(butter(4, [2000, 3000], btype="band", fs=fs, output="sos"), x)
    first_tick = dict(
        restitution=seq[0].result.restitution,
        contact_time=seq[0].result.contact_time,
        decay_time=_decay_time(x, fs),
        decay_time_2_3k=_decay_time(band, fs),
        edc_decay_time=_edc_decay_time(x, fs),
        edc_decay_time_2_3k=_edc_decay_time(band, fs),
        centroid=float(np.sum(f * spec) / np.sum(spec)),
        peak_pa=float(np.max(np.abs(x))),
    )
    out = dict(samplerate=samplerate, rows=rows, first_tick=first_tick)
    if modal:
        rows += thesis_modal_rows(samplerate=samplerate)
        out["surface"] = surface_fit()
    return out


#: Band of the impedance read from the modal plate (Hz): the band of an impact hammer and of
#: the contact pulses of Table 3.3 (their spectra fall off above about 1 / tau ~ 10 kHz).
MODAL_IMPEDANCE_BAND = (0.0, 10e3)
#: Restitution at the edge, 10 mm steel on 18 mm MDF, 1.4 m/s: the thesis' model (Eichler's
#: edge impedance) and its measurement, "about 5 % lower" (Chapter 3).
THESIS_EDGE_RESTITUTION = {"model": 0.63, "measured": 0.60}
#: Impact-speed bins (m/s) of the restitution at the end of a series.
LATE_SPEED_BINS = ((0.1, 0.2), (0.05, 0.1), (0.02, 0.05))


def modal_critical_distance(
    ball, plate, speed: float, step: float = 1e-3, **contact_options
) -> float:
    """Critical distance (m) of the modal plate: walking along the short midline from a long
    free edge, the distance at which the restitution stops rising, i.e. where, coming from the
    middle, it starts to fall (the thesis' definition, Table 3.3). The first local maximum of
    e on a grid of ``step`` (m), refined by a parabola through it and its neighbours.
    ``contact_options`` as in :func:`synth.physics.contact.contact_law`."""
    from synth.physics import modal_contact as mc

    base = mc.ModalContact.for_pair(ball, plate, None, speed=speed, **contact_options)

    def e_at(d):
        point = mc.modal_point(
            plate, (0.5 * plate.length, d), max_frequency=base.point.max_frequency
        )
        c = mc.ModalContact(
            point,
            base.mass,
            base.stiffness,
            base.exponent,
            base.gravity,
            base.steps_per_contact,
            base.dissipation,
        )
        return c.solve(speed).restitution

    e = [e_at(0.0), e_at(step)]
    d = step
    while d < 0.5 * plate.width - step:
        d += step
        e.append(e_at(d))
        if e[-2] >= e[-1] and e[-2] > e[-3]:
            y0, y1, y2 = e[-3], e[-2], e[-1]
            shift = 0.5 * (y0 - y2) / (y0 - 2.0 * y1 + y2)
            return d - step + shift * step
    return float("nan")


def _late_restitution_row(series, plain, lo_v: float, hi_v: float, label: str):
    """The thesis row of the mean restitution of ``series`` (the engine's ``label`` model)
    at speeds of ``lo_v``-``hi_v`` m/s late in the series, beside the impedance model's
    (``plain``)."""
    return thesis_row(
        f"restitution at {lo_v:g}-{hi_v:g} m/s, end of a series, {label}",
        "",
        _late_restitution(series, lo_v, hi_v),
        _late_restitution(plain, lo_v, hi_v),
        None,
        "model: the impedance model's; measured: e falls as the speed falls below 0.2 m/s",
    )


def _late_restitution(seq, lo, hi, spread=False):
    """Mean restitution of the impacts of ``seq`` at speeds in ``[lo, hi)`` (m/s), or with
    ``spread`` its standard deviation."""
    e = [i.restitution for i in seq if lo <= i.speed < hi]
    if not e:
        return float("nan")
    return float(np.std(e) if spread else np.mean(e))


def thesis_modal_rows(pairs=None, samplerate: int = 48000) -> list:
    """The rows of the thesis comparison for the modal plate (the finite plate's modes in the
    contact, :mod:`synth.physics.modal_contact`): restitution at the middle and at an edge,
    critical distances of the ball/board ``pairs`` (default: all of Table 3.3), impedance of
    the 18 mm board at the middle, an edge and a corner (band-averaged, Table 3.4), and the
    restitution at the end of a series (10 mm steel, 18 mm, from 10 cm) against the
    impedance model's; and with the fitted model (``contact.model = "fitted"``, MDF's fitted
    surface) the restitution and critical distances, the end of a series and the decay of
    ticks 1, 6 and 8 at the default scene's microphone (rendered at ``samplerate``, Hz)."""
    from synth.physics import modal_contact as mc
    from synth.physics.bounces import simulate_bounces
    from synth.physics.contact import solve_impact

    v1 = math.sqrt(2.0 * GRAVITY * 0.1)
    rows = []
    ball, plate = _thesis_pair("steel 10.0 mm", "18 mm")
    mid = mc.ModalContact.for_pair(ball, plate, None, speed=v1)
    rows.append(
        thesis_row(
            "restitution, modal plate, steel 10.0 mm on 18 mm, first impact (1.4 m/s)",
            "",
            mid.solve(v1).restitution,
            THESIS_RESTITUTION["model"],
            THESIS_RESTITUTION["measured"],
        )
    )
    edge = (0.5 * plate.length, 0.0)
    e_edge = mc.ModalContact.for_pair(ball, plate, edge, speed=v1).solve(v1).restitution
    rows.append(
        thesis_row(
            "restitution at a long edge, modal plate, steel 10.0 mm on 18 mm (1.4 m/s)",
            "",
            e_edge,
            THESIS_EDGE_RESTITUTION["model"],
            THESIS_EDGE_RESTITUTION["measured"],
            "measured: about 5 % below the model's 0.63",
        )
    )
    chosen = THESIS_IMPACTS if pairs is None else {k: THESIS_IMPACTS[k] for k in pairs}
    # widest band first on each board: the modes' cache then serves the narrower ones
    order = sorted(
        chosen, key=lambda k: solve_impact(*_thesis_pair(*k), v1, rtol=1e-6).contact_time
    )
    dc = {k: modal_critical_distance(*_thesis_pair(*k), v1) for k in order}
    for (ball_name, board_name), (tau_meas, _, dc_meas) in chosen.items():
        wave_speed = THESIS_BOARDS[board_name][4]
        rows.append(
            thesis_row(
                f"critical distance, modal plate, {ball_name} on {board_name}",
                "m",
                dc[ball_name, board_name],
                0.5 * tau_meas * wave_speed,
                dc_meas,
                "engine: where e stops rising from the edge; model: the thesis' tau c / 2",
            )
        )
    fitted = mc.ModalContact.for_pair(ball, plate, None, speed=v1, surface="fitted")
    rows.append(
        thesis_row(
            "restitution, fitted model (modal plate, MDF's fitted surface), steel 10.0 mm on "
            "18 mm, first impact (1.4 m/s)",
            "",
            fitted.solve(v1).restitution,
            THESIS_RESTITUTION["model"],
            THESIS_RESTITUTION["measured"],
            "the loss is fitted on this measurement",
        )
    )
    e_edge_fit = (
        mc.ModalContact.for_pair(ball, plate, edge, speed=v1, surface="fitted")
        .solve(v1)
        .restitution
    )
    rows.append(
        thesis_row(
            "restitution at a long edge, fitted model, steel 10.0 mm on 18 mm (1.4 m/s)",
            "",
            e_edge_fit,
            THESIS_EDGE_RESTITUTION["model"],
            THESIS_EDGE_RESTITUTION["measured"],
            "measured: about 5 % below the model's 0.63",
        )
    )
    dc_fit = {k: modal_critical_distance(*_thesis_pair(*k), v1, surface="fitted") for k in order}
    for (ball_name, board_name), (tau_meas, _, dc_meas) in chosen.items():
        rows.append(
            thesis_row(
                f"critical distance, fitted model, {ball_name} on {board_name}",
                "m",
                dc_fit[ball_name, board_name],
                0.5 * tau_meas * THESIS_BOARDS[board_name][4],
                dc_meas,
                "engine: where e stops rising from the edge; model: the thesis' tau c / 2",
            )
        )
    lo, hi = MODAL_IMPEDANCE_BAND
    for where, pos in (
        ("middle", plate.centre),
        ("edge", edge),
        ("corner", (0.0, 0.0)),
    ):
        z = mc.modal_point(plate, pos, max_frequency=mid.point.max_frequency).band_impedance(lo, hi)
        model, measured = THESIS_IMPEDANCE[where]
        rows.append(
            thesis_row(
                f"impedance, modal plate, 18 mm, {where}",
                "N s/m",
                z,
                model,
                measured,
                f"engine: 1 / <Re Y> over {lo / 1e3:g}-{hi / 1e3:g} kHz",
            )
        )
    modal = simulate_bounces(ball, plate, drop_height=0.1, plate_model="modal")
    plain = simulate_bounces(ball, plate, drop_height=0.1, rtol=1e-9)
    for lo_v, hi_v in LATE_SPEED_BINS:
        rows.append(_late_restitution_row(modal, plain, lo_v, hi_v, "modal plate"))
        rows.append(
            thesis_row(
                f"spread (standard deviation) of those restitutions at {lo_v:g}-{hi_v:g} m/s",
                "",
                _late_restitution(modal, lo_v, hi_v, spread=True),
                _late_restitution(plain, lo_v, hi_v, spread=True),
                None,
                "the ringing of earlier bounces scatters e from bounce to bounce",
            )
        )
    fitted_series = simulate_bounces(
        ball, plate, drop_height=0.1, plate_model="modal", surface="fitted"
    )
    for lo_v, hi_v in LATE_SPEED_BINS:
        rows.append(_late_restitution_row(fitted_series, plain, lo_v, hi_v, "fitted model"))
    from synth.io.presets import load_preset
    from synth.physics.bounces import simulate_scene

    scene = load_preset("default", ["contact.model=fitted"])
    decays = _tick_decay_times(scene, simulate_scene(scene), sorted(THESIS_TICK_DECAY), samplerate)
    for n, measured in THESIS_TICK_DECAY.items():
        rows.append(
            thesis_row(
                f"tick {n} decay at 20 cm, envelope peak to 37 %, fitted model",
                "s",
                decays[n],
                None,
                measured,
                "the thesis has no model of the sound",
            )
        )
    return rows


#: Restitution gaps of the thesis' measurements to its model (section 3.2; measured / model - 1):
#: (ball, board, impact speed in m/s) -> the measured gap, a value or a (low, high) range.
THESIS_RESTITUTION_GAPS = {
    ("steel 10.0 mm", "18 mm", 1.0): -0.18,
    ("steel 10.0 mm", "18 mm", 0.2): -0.08,
    ("steel 10.0 mm", "12 mm", 1.4): (-0.10, -0.05),
    ("steel 10.0 mm", "6 mm", 1.4): (0.10, 0.35),
}


#: Mass of the accelerometer waxed on the ball for the contact times of Table 3.3 (kg; "about
#: 1 g", with its cable, Chapter 3): the ball of those measurements is this much heavier.
THESIS_ACCELEROMETER_MASS = 1e-3


def _with_accelerometer(ball):
    """``ball`` as Table 3.3 measured it: with the accelerometer's mass added."""
    from dataclasses import replace

    return replace(ball, mass=ball.mass + THESIS_ACCELEROMETER_MASS)


def _surface_contact(ball, plate, ratio: float, mu: float, speed: float):
    """The first impact at ``speed`` (m/s) at the middle of ``plate``, the finite plate in the
    contact (:mod:`synth.physics.modal_contact`, band as its ``for_pair`` sets it) and the
    plate's side of the Hertz contact at ``ratio`` times its modulus with the Hunt-Crossley
    loss ``mu`` (s/m): a trial :class:`~synth.physics.materials.ContactSurface`."""
    from synth.physics import modal_contact as mc
    from synth.physics.contact import hertz_stiffness, solve_contact

    K = hertz_stiffness(ball, plate, ratio)
    beta = 1.0 / impedance.infinite_plate_impedance(plate)
    ref = solve_contact(
        mass=ball.mass, stiffness=K, admittance=beta, speed=speed, gravity=0.0, dissipation=mu
    )
    point = mc.modal_point(plate, plate.centre, max_frequency=mc.BAND_FACTOR / ref.contact_time)
    return mc.ModalContact(point, ball.mass, K, 1.5, GRAVITY, mc.STEPS_PER_CONTACT, mu).solve(speed)


def surface_fit(rounds: int = 4) -> dict:
    """MDF's contact surface (:class:`synth.physics.materials.ContactSurface`) fitted on the
    18 mm board only, with the finite plate in the contact at the middle of the board:

    * ``E_t / E`` on the five first-impact contact times of Table 3.3 (least squares of
      log tau), each ball with the accelerometer those measurements had on it
      (:data:`THESIS_ACCELEROMETER_MASS`);
    * the Hunt-Crossley loss ``mu`` on the restitution 0.76 of the 10 mm steel ball at 1.4 m/s
      (section 3.2).

    The two are coupled (the loss lengthens the contact a little, the softer contact changes
    e): ``rounds`` alternations of the two one-dimensional fits. Returns the two parameters,
    the stored ones (:data:`synth.physics.materials.MDF_SURFACE`) and one row per Table 3.3
    pair with the role (fit or prediction), the measured, thesis-model and engine contact
    times (the engine's with and without the accelerometer) and the bare ball's restitution;
    and the restitution rows of :data:`THESIS_RESTITUTION_GAPS` (engine with the
    stored surface, the thesis' model, the gap between them against the measured gap)."""
    from scipy.optimize import brentq, minimize_scalar

    from synth.physics.contact import solve_impact
    from synth.physics.materials import MDF_SURFACE

    v = math.sqrt(2.0 * GRAVITY * 0.1)
    fit_pairs = [k for k in THESIS_IMPACTS if k[1] == "18 mm"]
    pairs = {k: _thesis_pair(*k) for k in THESIS_IMPACTS}
    steel = pairs["steel 10.0 mm", "18 mm"]
    e_meas = THESIS_RESTITUTION["measured"]

    def measured_contact(k, r, mu):
        ball, plate = pairs[k]
        return _surface_contact(_with_accelerometer(ball), plate, r, mu, v)

    def tau_cost(log_ratio, mu):
        r = math.exp(log_ratio)
        return sum(
            math.log(measured_contact(k, r, mu).contact_time / THESIS_IMPACTS[k][0]) ** 2
            for k in fit_pairs
        )

    ratio, mu = MDF_SURFACE.transverse_ratio, MDF_SURFACE.dissipation
    for _ in range(rounds):
        mu = brentq(
            lambda m: _surface_contact(*steel, ratio, m, v).restitution - e_meas,
            0.0,
            2.0,
            xtol=1e-6,
        )
        best = minimize_scalar(
            tau_cost,
            bounds=(math.log(0.02), 0.0),
            args=(mu,),
            method="bounded",
            options=dict(xatol=1e-5),
        )
        ratio = math.exp(best.x)
    stored = (MDF_SURFACE.transverse_ratio, MDF_SURFACE.dissipation)
    rows = []
    for k, (tau_meas, model_ratio, _) in THESIS_IMPACTS.items():
        r = measured_contact(k, *stored)
        bare = _surface_contact(*pairs[k], *stored, v)
        rows.append(
            dict(
                ball=k[0],
                board=k[1],
                role="fit" if k in fit_pairs else "prediction",
                measured=tau_meas,
                model=tau_meas / model_ratio,
                contact_time=r.contact_time,
                error=r.contact_time / tau_meas - 1.0,
                bare_contact_time=bare.contact_time,
                restitution=bare.restitution,
            )
        )
    gaps = []
    for (ball_name, board, speed), measured in THESIS_RESTITUTION_GAPS.items():
        ball, plate = _thesis_pair(ball_name, board)
        engine = _surface_contact(ball, plate, *stored, speed).restitution
        model = solve_impact(ball, plate, speed, rtol=1e-9).restitution
        role = "fit board" if board == "18 mm" else "prediction"
        gaps.append(
            dict(
                ball=ball_name,
                board=board,
                speed=speed,
                role=role,
                engine=engine,
                model=model,
                gap=engine / model - 1.0,
                measured=measured,
            )
        )
    e_fit = _surface_contact(*steel, *stored, v).restitution
    return dict(
        ratio=ratio,
        dissipation=mu,
        stored_ratio=stored[0],
        stored_dissipation=stored[1],
        restitution=e_fit,
        rows=rows,
        gaps=gaps,
    )


def _gap_met(gap: float, measured) -> bool:
    """The issue's target for a restitution gap: the sign right and the size within half of
    the measured one (a range: within half of its nearer end outside it)."""
    lo, hi = measured if isinstance(measured, tuple) else (measured, measured)
    return (gap * lo > 0.0) and (
        0.5 * min(abs(lo), abs(hi)) <= abs(gap) <= 1.5 * max(abs(lo), abs(hi))
    )


def format_surface_fit(fit: dict) -> str:
    """The tables of :func:`surface_fit` (Markdown)."""
    lines = [
        f"MDF's contact surface, fitted on the 18 mm board only (modal plate, middle): "
        f"E_t / E = {fit['ratio']:.4f} (stored {fit['stored_ratio']:.4f}), Hunt-Crossley "
        f"mu = {fit['dissipation']:.4f} s/m (stored {fit['stored_dissipation']:.4f}); "
        f"e at 1.4 m/s with the stored values {fit['restitution']:.3f} (measured "
        f"{THESIS_RESTITUTION['measured']:.2f}). The 12 and 6 mm rows are predictions. "
        f"Contact times as Table 3.3 measured them: the ball carrying the "
        f"{THESIS_ACCELEROMETER_MASS * 1e3:g} g accelerometer (the bare ball's beside them).",
        "",
        "| ball on board | role | contact time measured (us) | thesis model (us) | engine, "
        "with the accelerometer (us) | error | engine, bare ball (us) | e at 1.4 m/s, bare ball |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for r in fit["rows"]:
        lines.append(
            f"| {r['ball']} on {r['board']} | {r['role']} | {r['measured'] * 1e6:.0f} | "
            f"{r['model'] * 1e6:.0f} | {r['contact_time'] * 1e6:.0f} | "
            f"{100 * r['error']:+.0f} % | {r['bare_contact_time'] * 1e6:.0f} | "
            f"{r['restitution']:.3f} |"
        )
    lines += [
        "",
        "Restitution against the thesis' model (gap = engine / model - 1; target: the measured "
        "gap's sign, and its size within half):",
        "",
        "| ball on board, speed | role | engine | thesis model | gap | measured gap | met |",
        "|---|---|---|---|---|---|---|",
    ]
    for g in fit["gaps"]:
        m = g["measured"]
        shown = (
            f"{100 * m[0]:+.0f} to {100 * m[1]:+.0f} %"
            if isinstance(m, tuple)
            else f"{100 * m:+.0f} %"
        )
        lines.append(
            f"| {g['ball']} on {g['board']}, {g['speed']:g} m/s | {g['role']} | "
            f"{g['engine']:.3f} | {g['model']:.3f} | {100 * g['gap']:+.1f} % | {shown} | "
            f"{'yes' if _gap_met(g['gap'], m) else 'no'} |"
        )
    return "\n".join(lines)


#: Display scale and format of each unit in the thesis table.
_THESIS_UNITS = {
    "": (1.0, "", "{:.3f}"),
    "s": (1e6, " (us)", "{:.0f}"),
    "m": (1e3, " (mm)", "{:.0f}"),
    "N s/m": (1.0, " (N s/m)", "{:.0f}"),
}


def _shown(value, scale, fmt):
    """A value (or a [low, high] range) of the thesis table, scaled and formatted."""
    if value is None:
        return "-"
    if isinstance(value, list | tuple):
        return "-".join(fmt.format(v * scale) for v in value)
    return fmt.format(value * scale)


def format_thesis(c: dict) -> str:
    """The table of :func:`thesis_comparison` (Markdown): engine, thesis model, thesis
    measurement and the engine's gap to the measurement, per quantity."""
    lines = [
        "| quantity | engine | thesis model | thesis measurement | engine - measurement |",
        "|---|---|---|---|---|",
    ]
    for row in c["rows"]:
        unit = row["unit"]
        scale, label, fmt = _THESIS_UNITS[unit]
        tick_ms = unit == "s" and row["quantity"].startswith("tick")
        if tick_ms:
            scale, label, fmt = 1e3, " (ms)", "{:.2f}"
        gap = row["gap"]
        if gap is None:
            gap_text = "-"
        elif row["relative_gap"] is not None:
            gap_text = f"{fmt.format(gap * scale)} ({100 * row['relative_gap']:+.0f} %)"
        else:
            gap_text = "inside" if gap == 0.0 else fmt.format(gap * scale)
        values = [_shown(row[k], scale, fmt) for k in ("engine", "model", "measured")]
        lines.append(f"| {row['quantity']}{label} | {' | '.join(values)} | {gap_text} |")
    t = c["first_tick"]
    lines += [
        "",
        "First tick at 20 cm, figures without a measured counterpart:",
        "",
        "| quantity | engine |",
        "|---|---|",
        f"| decay time, 2-3 kHz band, energy decay curve -5 to -25 dB, amplitude to 37 % "
        f"(ms) | {t['edc_decay_time_2_3k'] * 1e3:.1f} |",
        f"| decay time, 2-3 kHz band, envelope peak to 37 % (ms) | "
        f"{t['decay_time_2_3k'] * 1e3:.2f} |",
        f"| decay time, whole tick, energy decay curve (ms) | {t['edc_decay_time'] * 1e3:.1f} |",
        f'| spectral centroid (Hz; the thesis: "a few kHz") | {t["centroid"]:.0f} |',
        f"| peak pressure (Pa) | {t['peak_pa']:.1f} |",
    ]
    if c.get("surface") is not None:
        lines += ["", format_surface_fit(c["surface"])]
    return "\n".join(lines)


# ---------------------------------------------------------------------------------------
# Analysis against sounds the engine did not make
# ---------------------------------------------------------------------------------------
#: Modes of the benchmark's synthetic ticks: frequency (Hz), amplitude decay time (s),
#: relative amplitude; each file draws its own frequencies (+-3 %), decay times (+-20 %)
#: and phases.
_BOUNCE_MODES = (
    (620.0, 0.040, 1.0),
    (1370.0, 0.025, 0.8),
    (2450.0, 0.015, 0.7),
    (4100.0, 0.008, 0.5),
    (6900.0, 0.004, 0.4),
)


def synthetic_bounce(
    e: float,
    samplerate: int,
    *,
    t1: float = 0.15,
    n_ticks: int = 20,
    snr_db: float | None = None,
    seed: int = 0,
) -> tuple:
    """A bouncing sound with a known geometric restitution, not made by the engine.

    Bounce times ``T_n = t1 e^(n-1)`` (s); each tick is five damped sinusoids (0.6-7 kHz,
    decay times 4-40 ms) with amplitude proportional to the impact speed ``g T_n / 2``,
    started at its exact (sub-sample) onset. The seed draws the file's modal frequencies
    (+-3 %), decay times (+-20 %) and phases (the same for every tick: one impact point)
    and the noise. White noise at ``snr_db``: the mean power of the bouncing part (from
    the first onset to 50 ms after the last) over the noise power, dB, as in the tests.

    Parameters
    ----------
    e : float in (0, 1)
        Restitution, dimensionless.
    samplerate : int
        Hz.
    t1 : float > 0
        First bounce time, s.
    n_ticks : int >= 3
        Number of ticks.
    snr_db : float or None
        Signal-to-noise ratio, dB; ``None``: no noise.
    seed : int
        Random seed.

    Returns
    -------
    audio : ndarray of float64
    samplerate : int
        Hz.
    onsets : ndarray
        The true onsets, s.
    """
    rng = np.random.default_rng(seed)
    fs = samplerate
    T = t1 * e ** np.arange(n_ticks)
    onsets = 0.05 + np.r_[0.0, np.cumsum(T[:-1])]
    n = int((onsets[-1] + 0.3) * fs)
    x = np.zeros(n)
    base = np.array(_BOUNCE_MODES)
    freqs = base[:, 0] * rng.uniform(0.97, 1.03, base.shape[0])
    decays = base[:, 1] * rng.uniform(0.8, 1.2, base.shape[0])
    amps = base[:, 2]
    phase = rng.uniform(0.0, 2.0 * np.pi, base.shape[0])
    span = int(20 * decays.max() * fs)  # 20 decay times: < -170 dB, no audible cut
    for i, t0 in enumerate(onsets):
        speed = e**i
        k0 = int(np.ceil(t0 * fs))
        tt = np.arange(k0, min(n, k0 + span)) / fs - t0
        tick = np.sum(
            amps[:, None]
            * np.exp(-tt[None, :] / decays[:, None])
            * np.sin(2 * np.pi * freqs[:, None] * tt[None, :] + phase[:, None]),
            axis=0,
        )
        x[k0 : k0 + tt.size] += speed * tick
    if snr_db is not None:
        part = x[int(onsets[0] * fs) : int((onsets[-1] + 0.05) * fs)]
        p = np.mean(part**2)
        x = x + rng.standard_normal(n) * math.sqrt(p / 10 ** (snr_db / 10))
    return x, fs, onsets


def run_analysis(
    snrs=(None, 40.0, 30.0, 20.0, 10.0),
    restitutions=(0.6, 0.8, 0.9),
    seeds=10,
    samplerate: int = 48000,
) -> dict:
    """Accuracy of the recovered restitution (bounces 2-8) and onsets (ticks 1-8) against SNR.

    A true tick counts as found when a detected onset lies within 1 ms of it; the
    restitution and onset errors are over the found ticks only. A file in which nothing
    is detected (``AnalysisError``) counts all its ticks as missed.
    """
    from synth.analysis import AnalysisError, analyze

    rows = []
    for snr in snrs:
        errs, onset_errs, found, missed = [], [], 0, 0
        t0 = time.perf_counter()
        for e in restitutions:
            for seed in range(seeds):
                x, fs, onsets = synthetic_bounce(e, samplerate, snr_db=snr, seed=seed)
                try:
                    a = analyze(x, fs)
                except AnalysisError:  # no tick found at all: all missed
                    missed += 8
                    continue
                got = np.array([t.time for t in a.ticks])
                for i in range(8):
                    j = int(np.argmin(np.abs(got - onsets[i])))
                    if abs(got[j] - onsets[i]) > 1e-3:
                        missed += 1
                        continue
                    found += 1
                    onset_errs.append(got[j] - onsets[i])
                    tick = a.ticks[j]
                    if i >= 2 and tick.restitution is not None:
                        errs.append(abs(tick.restitution - e) / e)
        n_files = len(restitutions) * seeds
        rows.append(
            dict(
                snr_db=snr,
                files=n_files,
                ticks_found=found,
                ticks_missed=missed,
                e_error_median=float(np.median(errs)) if errs else float("nan"),
                e_error_p95=float(np.percentile(errs, 95)) if errs else float("nan"),
                e_error_max=float(np.max(errs)) if errs else float("nan"),
                onset_error_rms_ms=float(np.sqrt(np.mean(np.square(onset_errs)))) * 1e3
                if onset_errs
                else float("nan"),
                seconds_per_file=(time.perf_counter() - t0) / n_files,
            )
        )
    return dict(samplerate=samplerate, restitutions=list(restitutions), rows=rows)


def format_analysis(result) -> str:
    """The table of :func:`run_analysis` (Markdown)."""
    lines = [
        f"synthetic bounces: e in {result['restitutions']}, {result['rows'][0]['files']} files "
        f"per SNR, bounces 2-8 (e) and ticks 1-8 (onsets), {result['samplerate']} Hz; SNR: "
        f"power of the bouncing part over the noise's; errors over the ticks found",
        "| SNR (dB) | ticks found / missed | e error, median | e error, 95th percentile | "
        "e error, max | onset error, RMS (ms) | analysis time per file (ms) |",
        "|---|---|---|---|---|---|---|",
    ]
    for r in result["rows"]:
        snr = "no noise" if r["snr_db"] is None else f"{r['snr_db']:.0f}"
        lines.append(
            f"| {snr} | {r['ticks_found']} / {r['ticks_missed']} | {r['e_error_median']:.2e} | "
            f"{r['e_error_p95']:.2e} | {r['e_error_max']:.2e} | {r['onset_error_rms_ms']:.3f} | "
            f"{r['seconds_per_file'] * 1e3:.0f} |"
        )
    return "\n".join(lines)


# ----------------------------------------------------------------------------------------
# Long recordings: analysis time and memory against the length and the number of drops

#: Lengths of the recordings of the long-recording benchmark, s.
LONG_DURATIONS = (30.0, 120.0, 600.0)
#: One drop every this many seconds in the recordings of repeated drops, s.
LONG_PERIOD = 10.0
#: The target for a 10-minute recording: analysed in under this many seconds, s...
LONG_TARGET_S = 30.0
#: ... and a process' peak resident set under this, MB.
LONG_TARGET_MB = 500.0


def long_recording(path, duration: float, repeated: bool, samplerate: int = 48000) -> int:
    """Write a recording of ``duration`` s (float32 WAV) to ``path``: white noise 80 dB under
    full scale and a synthetic bounce (:func:`synthetic_bounce`, e = 0.8, 20 ticks; a new
    seed per drop) starting at 1 s, and with ``repeated`` again every :data:`LONG_PERIOD` s.
    Written in pieces of a drop's period (the file is never in memory whole). Returns the
    number of true ticks."""
    import soundfile

    fs = samplerate
    rng = np.random.default_rng(0)
    total = int(round(duration * fs))
    period = int(round(LONG_PERIOD * fs))
    ticks = 0
    with soundfile.SoundFile(
        path, "w", samplerate=fs, channels=1, subtype="FLOAT", format="WAV"
    ) as f:
        for k, start in enumerate(range(0, total, period)):
            n = min(period, total - start)
            y = rng.standard_normal(n) * 1e-4
            if k == 0 or repeated:
                x, _, onsets = synthetic_bounce(0.8, fs, seed=k)
                m = min(x.size, n - fs)
                if m > 0:
                    y[fs : fs + m] += 0.5 * x[:m]
                    ticks += int(np.count_nonzero(onsets + 1.0 < n / fs))
            f.write(y.astype(np.float32))
    return ticks


def long_child(path: str) -> dict:
    """Analyse the file ``path`` in this process: wall seconds, CPU seconds (the process'
    threads), the peak of the memory allocated meanwhile (tracemalloc, MB), ticks and series
    found."""
    import tracemalloc

    from synth.analysis import analyze_file

    tracemalloc.start()
    t0, c0 = time.perf_counter(), time.process_time()
    a = analyze_file(path)
    seconds, cpu = time.perf_counter() - t0, time.process_time() - c0
    peak = tracemalloc.get_traced_memory()[1] / 1e6
    tracemalloc.stop()
    return {
        "seconds": seconds,
        "cpu_s": cpu,
        "traced_mb": peak,
        "ticks": len(a.ticks),
        "series": len(a.series),
    }


def run_long(durations=LONG_DURATIONS, timeout: float = 1800.0) -> list:
    """Each recording of :func:`long_recording` (one drop, and repeated drops) analysed by
    ``analyze_file`` in a new process (after a warm-up on a short file, which loads numba's
    cache): wall and CPU seconds, traced peak MB, the process' peak resident MB
    (``ru_maxrss``: the interpreter and libraries too), wall and CPU seconds per minute of
    audio, and ticks found against the truth."""
    import os
    import tempfile

    code = (
        "import json, resource, sys; from synth import bench; "
        "bench.long_child(sys.argv[2]); r = bench.long_child(sys.argv[1]); "
        "r['rss_mb'] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0; "
        "print(json.dumps(r))"
    )
    rows = []
    with tempfile.TemporaryDirectory(prefix="synth-long-") as tmp:
        warm = os.path.join(tmp, "warm.wav")
        long_recording(warm, 3.0, False)
        for repeated in (False, True):
            for duration in durations:
                path = os.path.join(tmp, "long.wav")
                truth = long_recording(path, duration, repeated)
                row = {"duration": duration, "repeated": repeated, "truth": truth}
                row.update(_child_json(code, [path, warm], timeout))
                if "error" not in row:
                    row["per_minute"] = row["seconds"] / (duration / 60.0)
                    row["cpu_per_minute"] = row["cpu_s"] / (duration / 60.0)
                rows.append(row)
    return rows


def format_long(rows) -> str:
    """The long-recording benchmark as a Markdown table, then the 10-minute recordings against
    the target (:data:`LONG_TARGET_S`, :data:`LONG_TARGET_MB`)."""
    lines = [
        "| recording | ticks (truth) | series | analysis s (CPU s) | s per minute of audio "
        "(CPU) | traced peak MB | process peak MB |",
        "|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        what = _long_name(r)
        if "error" in r:
            lines.append(f"| {what} | ({r['truth']}) | failed: {r['error']} | | | | |")
            continue
        lines.append(
            f"| {what} | {r['ticks']} ({r['truth']}) | {r['series']} | {r['seconds']:.2f} "
            f"({r['cpu_s']:.2f}) | {r['per_minute']:.2f} ({r['cpu_per_minute']:.2f}) | "
            f"{r['traced_mb']:.0f} | {r['rss_mb']:.0f} |"
        )
    lines.append("")
    lines.append(
        "Synthetic bounces (e = 0.8, 20 ticks each) in white noise 80 dB under full scale, "
        "48 kHz float WAV, each analysed by `analyze_file` in a new process after a warm-up "
        "on a 3 s file. CPU: the process' threads (a multithreaded BLAS's helpers too). "
        "'traced peak': the largest memory allocated during the analysis (tracemalloc); "
        "'process peak': the process' largest resident set (ru_maxrss, with the interpreter "
        "and libraries)."
    )
    longest = [r for r in rows if r["duration"] >= 600.0 and "error" not in r]
    if longest:
        lines.append("")
        for r in longest:
            met = r["seconds"] < LONG_TARGET_S and r["rss_mb"] < LONG_TARGET_MB
            lines.append(
                f"- {_long_name(r)}: {r['seconds']:.1f} s ({r['cpu_s']:.1f} s CPU), process "
                f"peak {r['rss_mb']:.0f} MB: target under {LONG_TARGET_S:g} s and "
                f"{LONG_TARGET_MB:g} MB {'met' if met else 'not met'}."
            )
    return "\n".join(lines)


def _long_name(r: dict) -> str:
    """A row's recording: its length and drops."""
    return f"{r['duration']:g} s, " + (
        f"a drop every {LONG_PERIOD:g} s" if r["repeated"] else "one drop"
    )


def markdown_block(command: str, table: str) -> str:
    """A benchmark's output as a block for docs/: one line naming the command, the date and
    the machine (CPUs, load average), then the benchmark's Markdown tables."""
    import datetime
    import os
    import platform

    import numba

    now = datetime.datetime.now(datetime.UTC).strftime("%Y-%m-%d %H:%M UTC")
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    head = (
        f"Printed by `{command}` on {now} (Python {platform.python_version()}, "
        f"numba {numba.__version__}, {os.cpu_count()} CPUs, load average {load:.1f} "
        "at the end of the run)."
    )
    return f"{head}\n\n{table}\n"


# ----------------------------------------------------------------------------------------
# Scale: cold and warm costs of modes, radiation gains and synthesis for a ladder of plates


SCALE_LADDER = (
    # name, material, thickness m, length m, width m, boundary, samplerate Hz
    ("small stiff glass", "glass", 0.010, 0.15, 0.10, "clamped", 48000),
    ("glass table", "glass", 0.008, 1.0, 0.6, "simply-supported", 48000),
    ("steel sheet", "steel", 0.001, 0.5, 0.4, "free", 22050),
    ("steel sheet", "steel", 0.001, 0.5, 0.4, "free", 48000),
    ("thunder sheet", "steel", 0.001, 1.5, 1.0, "simply-supported", 48000),
    ("2 m thin metal", "steel", 0.0021, 1.86, 1.86, "simply-supported", 44100),
    ("free bar", "steel", 0.0037, 1.84, 0.10, "free", 48000),
    # the two named plates had more modes than these steel ones (34 161 to
    # 22.05 kHz and 4614 to 24 kHz, of materials not in the table): the same sizes in the
    # table's materials with at least as many modes carry the targets
    ("1.86 m plate", "abs", 0.0021, 1.86, 1.86, "simply-supported", 44100),
    ("1.84 m bar", "rubber", 0.0037, 1.84, 0.10, "free", 48000),
)
#: The ladder's plates that carry the issue's two named targets, and the fewest modes each
#: must have (the issue's plates' own counts).
SCALE_NAMED = {"1.86 m plate": 34161, "1.84 m bar": 4614}


#: Random valid scenes of the scale benchmark (each cold in its own process) and the
#: seed that draws them (:func:`random_scale_specs`).
SCALE_RANDOM = 8
SCALE_SEED = 16
_RANDOM_MATERIALS = ("steel", "aluminium", "glass", "brass", "acrylic", "plywood")
_RANDOM_RATES = (22050, 44100, 48000)
_BOUNDARIES = ("free", "simply-supported", "clamped")


def random_scale_specs(count: int, seed: int = SCALE_SEED) -> list:
    """``count`` random valid plates as the issue's new user would pick them: sides
    0.1-2 m, thickness 1-40 mm (log-uniform), any of six materials and the three
    boundaries, 22.05-48 kHz; specs for :func:`scale_child`."""
    rng = np.random.default_rng(seed)
    specs = []
    for _ in range(count):
        a, b = rng.uniform(0.1, 2.0, 2)
        specs.append(
            {
                "material": _RANDOM_MATERIALS[int(rng.integers(len(_RANDOM_MATERIALS)))],
                "thickness": float(np.exp(rng.uniform(np.log(0.001), np.log(0.04)))),
                "length": float(a),
                "width": float(b),
                "boundary": _BOUNDARIES[int(rng.integers(3))],
                "samplerate": int(_RANDOM_RATES[int(rng.integers(len(_RANDOM_RATES)))]),
            }
        )
    return specs


def _scale_scene(material, thickness, length, width, boundary):
    """A 16 mm glass marble dropped 10 cm on a point off the middle (0.4, 0.45 of each
    side), microphone 0.4 m above the middle."""
    from synth.io import presets

    scene, _, _ = presets.load_preset_with_options(
        "glass-marble-on-glass-table",
        [
            f"plate.material='{material}'",
            f"plate.thickness={thickness!r}",
            f"plate.length={length!r}",
            f"plate.width={width!r}",
            f"plate.boundary='{boundary}'",
            f"drop.position=[{0.4 * length!r}, {0.45 * width!r}]",
            f"listener.position=[{0.5 * length!r}, {0.5 * width!r}, 0.4]",
        ],
    )
    return scene


def _peak_rss_mb() -> float:
    import resource

    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0  # Linux: KiB


def scale_child(spec: dict) -> dict:
    """One plate of the ladder in this process: seconds and peak resident memory (MB)
    after the modes, the microphone's gains and the whole render (whose modes and
    gains then come from the memory cache: the rest is contact, scheduler and
    synthesis)."""
    from synth.sound import modes as plate_modes
    from synth.sound import render as render_mod
    from synth.sound.radiation import plate_gains

    scene = _scale_scene(
        spec["material"], spec["thickness"], spec["length"], spec["width"], spec["boundary"]
    )
    fs = spec["samplerate"]
    out = {}
    t0 = time.perf_counter()
    try:
        modes = plate_modes.modes(scene.plate, max_frequency=0.5 * fs * (1.0 - 1e-9))
    except Exception as exc:  # noqa: BLE001 - a refusal is a figure of this benchmark
        return {"error": f"{type(exc).__name__}: {exc}"}
    out["modes_s"] = time.perf_counter() - t0
    out["n_modes"] = len(modes)
    out["modes_mb"] = _peak_rss_mb()
    omega = np.asarray(modes.angular_frequencies)
    sigma = np.asarray(modes.decay_rates)
    poles = -sigma + 1j * np.sqrt(np.maximum(omega**2 - sigma**2, 0.0))
    k_max = (
        float(omega.max()) ** 2 * scene.plate.surface_density / scene.plate.flexural_rigidity
    ) ** 0.25
    t0 = time.perf_counter()
    result = plate_gains(
        modes,
        scene.listener.position,
        -np.conj(poles),
        max_wavenumber=k_max,
        reference_distance=render_mod.nearest_distance(scene.plate, scene.listener),
        full_output=True,
    )
    out["gains_s"] = time.perf_counter() - t0
    out["gains_mb"] = _peak_rss_mb()
    out["rule"] = result.rule
    t0 = time.perf_counter()
    r = render_mod.render(scene, samplerate=fs)
    out["render_s"] = time.perf_counter() - t0
    out["render_mb"] = _peak_rss_mb()
    out["audio_s"] = r.duration
    return out


def _child_json(code: str, argv: list, timeout: float, cache_dir=None) -> dict:
    """Run ``python -c code *argv`` in a new process (with ``SYNTH_CACHE_DIR=cache_dir``
    if given) and return the JSON object its last line of output prints, with
    ``process_s`` its wall time (s); or ``{"error": ...}`` saying why there is none (a
    timeout, a signal, or the last line of its error output)."""
    import json
    import os
    import subprocess
    import sys

    env = (
        dict(os.environ) if cache_dir is None else dict(os.environ, SYNTH_CACHE_DIR=str(cache_dir))
    )
    t0 = time.perf_counter()
    try:
        proc = subprocess.run(
            [sys.executable, "-c", code, *argv],
            env=env,
            capture_output=True,
            text=True,
            timeout=timeout,
            check=False,
        )
    except subprocess.TimeoutExpired:
        return {"error": f"over {timeout:g} s"}
    wall = time.perf_counter() - t0
    if proc.returncode < 0:
        return {"error": f"stopped by signal {-proc.returncode} after {wall:.0f} s"}
    if proc.returncode != 0:
        lines = proc.stderr.strip().splitlines()
        return {"error": lines[-1] if lines else "failed"}
    res = json.loads(proc.stdout.strip().splitlines()[-1])
    res["process_s"] = wall
    return res


def _scale_run(spec, cache_dir, timeout):
    import json

    code = (
        "import json, sys; from synth import bench; "
        "print(json.dumps(bench.scale_child(json.loads(sys.argv[1]))))"
    )
    return _child_json(code, [json.dumps(spec)], timeout, cache_dir)


def run_scale(ladder=SCALE_LADDER, timeout=600.0, random=SCALE_RANDOM) -> list:
    """Each plate of ``ladder``, then ``random`` random valid plates
    (:func:`random_scale_specs`), rendered in a new process with an empty cache directory
    (cold), then in another process with that directory (warm: modes and gains from
    disk). Seconds and peak memory of each stage; see :func:`scale_child`."""
    import tempfile

    rows = []
    for name, material, h, a, b, boundary, fs in ladder:
        spec = {
            "material": material,
            "thickness": h,
            "length": a,
            "width": b,
            "boundary": boundary,
            "samplerate": fs,
        }
        with tempfile.TemporaryDirectory(prefix="synth-scale-") as tmp:
            cold = _scale_run(spec, tmp, timeout)
            warm = _scale_run(spec, tmp, timeout) if "error" not in cold else cold
        rows.append({"name": name, **spec, "cold": cold, "warm": warm})
    for i, spec in enumerate(random_scale_specs(random)):
        with tempfile.TemporaryDirectory(prefix="synth-scale-") as tmp:
            cold = _scale_run(spec, tmp, timeout)
            warm = _scale_run(spec, tmp, timeout) if "error" not in cold else cold
        rows.append({"name": f"random {i + 1}", **spec, "cold": cold, "warm": warm})
    return rows


#: Targets of the scale benchmark (the issue's): the random scenes' median cold work
#: (modes, gains and render in a new process), s; the longest any may take, s (or the
#: audio's own length if longer); peak resident memory, MB; the 1.86 m simply supported
#: plate's cold work, s; the free 1.84 x 0.10 m bar's cold modes to 24 kHz, s.
SCALE_TARGETS = {
    "median_s": 2.0,
    "slowest_s": 15.0,
    "peak_mb": 2048.0,
    "thin_metal_s": 5.0,
    "bar_modes_s": 3.0,
}


def _work_s(run: dict) -> float:
    """Seconds of a run's modes, gains and render (the process without the interpreter,
    imports and numba's cache loading)."""
    return run["modes_s"] + run["gains_s"] + run["render_s"]


def _stage(run: dict, key: str) -> str:
    """``seconds (peak MB)`` of one stage of a run, or a dash."""
    if not run or "error" in run:
        return "-"
    return f"{run[key + '_s']:.3g} ({run[key + '_mb']:.0f})"


def _cold_warm(figure, cold: dict, warm: dict) -> str:
    """``figure(cold) / figure(warm)``, a dash for a missing or failed warm run."""
    ok = bool(warm) and "error" not in warm
    return f"{figure(cold)} / {figure(warm) if ok else '-'}"


def format_scale(rows) -> str:
    """The scale benchmark as a Markdown table (cold / warm) and the targets' verdicts."""
    lines = [
        (
            "| plate | fs Hz | modes | modes s (MB) | gains s (MB), rule | render s (MB) | "
            "work s | process s | audio s |"
        ),
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for row in rows:
        plate = (
            f"{row['name']}: {row['material']} {row['length']:.3g} x {row['width']:.3g} x "
            f"{row['thickness'] * 1e3:.3g} mm {row['boundary']}"
        )
        c, w = row["cold"], row["warm"]
        if "error" in c:
            lines.append(
                f"| {plate} | {row['samplerate']} | refused or failed: {c['error']} | | | | | | |"
            )
            continue
        lines.append(
            f"| {plate} | {row['samplerate']} | {c['n_modes']} | "
            f"{_cold_warm(lambda r: _stage(r, 'modes'), c, w)} | "
            f"{_cold_warm(lambda r: _stage(r, 'gains'), c, w)}, {c['rule']} | "
            f"{_cold_warm(lambda r: _stage(r, 'render'), c, w)} | "
            f"{_cold_warm(lambda r: format(_work_s(r), '.3g'), c, w)} | "
            f"{_cold_warm(lambda r: format(r['process_s'], '.3g'), c, w)} | "
            f"{c['audio_s']:.2f} |"
        )
    lines += _random_summary(rows)
    lines += _ladder_targets(rows)
    lines.append("")
    lines.append(
        "Cold: a new process with an empty SYNTH_CACHE_DIR; warm: a second process "
        "with the first one's cache. Each stage: seconds and, in brackets, the process' "
        "peak resident memory after it (MB). 'render s' is the whole render after the "
        "modes and gains are in memory (contact, bounces, synthesis); 'work s' the three "
        "stages; 'process s' adds the interpreter, imports and numba's cache loading."
    )
    return "\n".join(lines)


def _verdict(met: bool) -> str:
    return "met" if met else "NOT met"


def _random_summary(rows) -> list:
    """The random scenes' cold work (median, largest), process time, peak memory, how many
    were refused or took longer than max(15 s, their audio's length), with the targets'
    verdicts (:data:`SCALE_TARGETS`)."""
    runs = [r["cold"] for r in rows if r["name"].startswith("random")]
    if not runs:
        return []
    done = [c for c in runs if "error" not in c]
    t = SCALE_TARGETS
    lines = ["", f"Random valid scenes ({len(runs)}, seed {SCALE_SEED}), cold:"]
    if not done:
        return lines + [f"refused or failed: {len(runs)}."]
    work = np.array([_work_s(c) for c in done])
    proc = np.array([c["process_s"] for c in done])
    mb = np.array([c["render_mb"] for c in done])
    slow = sum(_work_s(c) > max(t["slowest_s"], c["audio_s"]) for c in done)
    failed = len(runs) - len(done)
    lines.append(
        f"work median {np.median(work):.3g} s, max {work.max():.3g} s (process median "
        f"{np.median(proc):.3g} s, max {proc.max():.3g} s), peak memory max {mb.max():.0f} MB; "
        f"slower than max(15 s, audio length): {slow}; refused or failed: {failed}."
    )
    lines.append(
        f"Targets: median under {t['median_s']:g} s {_verdict(np.median(work) < t['median_s'])}; "
        f"none slower than max({t['slowest_s']:g} s, audio length) "
        f"{_verdict(slow == 0 and failed == 0)}; peak under {t['peak_mb'] / 1024:g} GB "
        f"{_verdict(mb.max() < t['peak_mb'])}."
    )
    return lines


def _ladder_targets(rows) -> list:
    """Verdicts of the ladder's two named targets: the 1.86 m simply supported plate's cold
    work and the free bar's cold modes (:data:`SCALE_TARGETS`), where they ran."""
    t = SCALE_TARGETS
    out = []
    for row in rows:
        c = row["cold"]
        if "error" in c:
            continue
        if row["name"] == "1.86 m plate":
            out.append(
                f"1.86 m simply supported plate ({row['material']}, {c['n_modes']} modes; the "
                f"issue's had {SCALE_NAMED[row['name']]}), cold work {_work_s(c):.3g} s: under "
                f"{t['thin_metal_s']:g} s {_verdict(_work_s(c) < t['thin_metal_s'])}."
            )
        if row["name"] == "1.84 m bar":
            out.append(
                f"Free 1.84 x 0.10 m bar ({row['material']}, {c['n_modes']} modes; the issue's "
                f"had {SCALE_NAMED[row['name']]}) to {row['samplerate'] // 2} Hz, cold modes "
                f"{c['modes_s']:.3g} s: under {t['bar_modes_s']:g} s "
                f"{_verdict(c['modes_s'] < t['bar_modes_s'])}."
            )
    return [""] + out if out else []


# ----------------------------------------------------------------------------------------
# High sample rates: cold renders of the default preset

#: Sample rates of the hires benchmark, Hz; the last is also rendered with the previous paths.
HIRES_RATES = (96000, 192000, 384000)


def hires_child(samplerate: int, previous: bool = False) -> dict:
    """A cold render of the default preset at ``samplerate`` Hz in this process: seconds
    of the plate's modes, of the rest of the first render (radiation gains, contact,
    synthesis), of a second render (warm: the rest without the gains), and peak resident
    memory (MB). ``previous``: with the engine's former paths, the rectangle rule for
    every plate (:data:`synth.sound.radiation.SUMMED_RULE_WORK` infinite) and the Ritz
    solve on BLAS's threads at every size
    (:data:`synth.sound.modes.ONE_THREAD_UNKNOWNS` infinite)."""
    from synth.io.presets import load_preset
    from synth.sound import modes as plate_modes
    from synth.sound import radiation
    from synth.sound.render import render

    if previous:
        radiation.SUMMED_RULE_WORK = math.inf
        plate_modes.ONE_THREAD_UNKNOWNS = math.inf
    scene = load_preset("default")
    t0 = time.perf_counter()
    modes = plate_modes.modes(scene.plate, max_frequency=0.5 * samplerate * (1.0 - 1e-9))
    t1 = time.perf_counter()
    first = render(scene, samplerate=samplerate)
    t2 = time.perf_counter()
    render(scene, samplerate=samplerate)
    t3 = time.perf_counter()
    return {
        "n_modes": len(modes),
        "modes_s": t1 - t0,
        "first_s": t2 - t1,
        "warm_s": t3 - t2,
        "peak_mb": _peak_rss_mb(),
        "audio_s": first.duration,
        "gains": radiation.cache_info()["computations"],
    }


def _hires_run(samplerate, previous, timeout):
    import tempfile

    code = (
        "import json, sys; from synth import bench; "
        "print(json.dumps(bench.hires_child(int(sys.argv[1]), sys.argv[2] == '1')))"
    )
    with tempfile.TemporaryDirectory(prefix="synth-hires-") as tmp:
        return _child_json(code, [str(samplerate), "1" if previous else "0"], timeout, tmp)


def run_hires(rates=HIRES_RATES, timeout=3600.0) -> dict:
    """Cold renders of the default preset (a new process, an empty SYNTH_CACHE_DIR) at
    each of ``rates`` (Hz), and at the last one again with the previous paths (see
    :func:`hires_child`); ``ratio`` is the previous process's seconds over the present
    one's at that rate."""
    rows = [
        {"samplerate": fs, "paths": "present", **_hires_run(fs, False, timeout)} for fs in rates
    ]
    rows.append(
        {"samplerate": rates[-1], "paths": "previous", **_hires_run(rates[-1], True, timeout)}
    )
    now, before = rows[-2], rows[-1]
    ratio = (
        before["process_s"] / now["process_s"]
        if "error" not in now and "error" not in before
        else None
    )
    return {"rows": rows, "ratio": ratio}


def format_hires(result) -> str:
    """The hires benchmark as a Markdown table."""
    lines = [
        "| fs Hz | paths | modes | modes s | gains + render s | warm render s | process s | "
        "peak MB |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for r in result["rows"]:
        if "error" in r:
            lines.append(f"| {r['samplerate']} | {r['paths']} | failed: {r['error']} | | | | | |")
            continue
        lines.append(
            f"| {r['samplerate']} | {r['paths']} | {r['n_modes']} | {r['modes_s']:.1f} | "
            f"{r['first_s']:.1f} | {r['warm_s']:.1f} | {r['process_s']:.1f} | "
            f"{r['peak_mb']:.0f} |"
        )
    lines.append("")
    if result["ratio"] is not None:
        lines.append(
            f"Cold render at {result['rows'][-1]['samplerate']} Hz: previous paths / present "
            f"paths = {result['ratio']:.1f}x (process seconds)."
        )
    lines.append(
        "Cold: a new process with an empty SYNTH_CACHE_DIR renders the default preset "
        "(`synth render default --samplerate FS`). 'modes s': the plate's modes; 'gains + "
        "render s': the first render after them (radiation gains, contact, bounces, "
        "synthesis); 'warm render s': a second render (gains from memory); 'process s' "
        "includes the interpreter, imports and numba's cache loading. Previous paths: the "
        "rectangle rule for every plate and the Ritz solve on BLAS's threads at every size."
    )
    return "\n".join(lines)
