"""Benchmarks: numerical error against run time (``synth bench ...``).

Every figure is measured in one run on this machine, after a warm-up. Nothing
here is imported by the rest of the engine.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from . import contact, impedance
from .scene import Ball, Plate


@dataclass(frozen=True)
class ContactCase:
    """A benchmark impact, in lumped parameters (SI)."""

    name: str
    mass: float          # kg
    stiffness: float     # N/m^n
    admittance: float    # m/(N s)
    speed: float         # m/s
    gravity: float       # m/s^2
    exponent: float = 1.5
    dissipation: float = 0.0   # s/m


def _case(name, ball, plate, speed, gravity=9.81, contact_law="hertz", **kw):
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
        _case("steel 20 mm on aluminium 4 mm, 1 m/s (lam > 1)", Ball("steel", 0.01),
              Plate("aluminium", 0.004, 1.0, 0.8), 1.0),
        _case("steel 10 mm on MDF 18 mm, 1 mm/s (gravity)", steel10, mdf18, 1e-3),
        _case("steel 50 mm on aluminium 0.5 mm, 5 m/s (stiff, Radau)", Ball("steel", 0.025),
              Plate("aluminium", 0.0005, 1.0, 0.8), 5.0),
        _case("glass 12.55 mm on MDF 6 mm, Hunt-Crossley mu=0.2 s/m", Ball("glass", 0.006275),
              Plate("mdf-6", 0.00615, 1.2, 0.4895), 1.4, contact_law="hunt-crossley",
              dissipation=0.2),
    ]


def _scaled(case):
    v0 = case.speed
    n = case.exponent
    theta = (case.mass / (case.stiffness * v0 ** (n - 1.0))) ** (1.0 / (n + 1.0))
    lam = case.admittance * case.mass / theta
    G = case.gravity * theta / v0
    return theta, lam, G, case.dissipation * v0


def scipy_contact(case, method="Radau", rtol=1e-12, atol=1e-15):
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
        a = x ** n
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
        a = x ** n
        da = n * a / x
        if c == 0.0:
            fx, fw = da, 0.0
        else:
            num, den = 1.0 + c * w, 1.0 + c * lam * a
            fx, fw = (da * num / den ** 2, a * c / den) if num > 0 else (0.0, 0.0)
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
    sol = solve_ivp(rhs, (s0, 1e9), y0, method=method, rtol=rtol, atol=atol, events=events,
                    dense_output=True, **kw)
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
    a = x ** n
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


def run_contact(tolerances=(1e-3, 1e-4, 1e-6, 1e-8, 1e-10), repeat=300):
    """Error of e, tau and the pulse against the reference, and time per impact.

    Returns a dict with ``rows`` (one per case and tolerance; the default rtol 1e-6 is
    always measured), ``scipy`` (for each case: our time at the default rtol, scipy
    DOP853's time at matched error, ratio), ``gravity`` (for each case: the time with
    and without gravity and the change of e that gravity makes) and ``summary`` (the
    targets and the figures that meet them or not). Errors are None where undefined.
    """
    tolerances = tuple(sorted(set(float(t) for t in tolerances) | {DEFAULT_RTOL}, reverse=True))
    cases = contact_cases()
    rows = []
    comparisons = []
    gravity_rows = []
    # warm up the kernels (compilation is cached on disk, but the first call loads it)
    for meth in ("DOP853", "Radau"):
        contact.solve_contact(mass=1e-3, stiffness=1e9, admittance=1e-3, speed=1.0, method=meth)
    for case in cases:
        e_ref, tau_ref, sol, theta = scipy_contact(case)
        kw = dict(mass=case.mass, stiffness=case.stiffness, admittance=case.admittance,
                  speed=case.speed, gravity=case.gravity, exponent=case.exponent,
                  dissipation=case.dissipation)
        ours_default = None
        for tol in tolerances:
            res = contact.solve_contact(rtol=tol, **kw)
            t = _median_time(lambda: contact.solve_contact(rtol=tol, **kw), repeat)
            err_e = abs(res.restitution - e_ref) / max(e_ref, 1e-300) if e_ref > 0 else abs(res.restitution)
            row = dict(case=case.name, rtol=tol, restitution=res.restitution,
                       inelasticity=res.inelasticity, settled=res.settled,
                       err_restitution=err_e,
                       err_contact_time=abs(res.contact_time - tau_ref) / tau_ref,
                       err_pulse=_pulse_error(res, sol, theta, case),
                       energy_residual=res.energy_residual, steps=res.n_steps,
                       method=res.method, us_per_impact=t * 1e6)
            rows.append(row)
            if tol == DEFAULT_RTOL:
                ours_default = row
        # scipy DOP853 at matched error: the loosest rtol whose errors are no larger
        target = max(ours_default["err_restitution"], ours_default["err_contact_time"], 1e-13)
        match = None
        for srtol in (1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-11, 1e-12, 1e-13):
            e_s, tau_s, _, _ = scipy_contact(case, "DOP853", rtol=srtol, atol=srtol * 1e-6)
            err = max(abs(e_s - e_ref) / max(e_ref, 1e-300) if e_ref > 0 else abs(e_s),
                      abs(tau_s - tau_ref) / tau_ref)
            if err <= target:
                match = (srtol, err)
                break
        srtol, err = match if match is not None else (1e-13, None)
        reps = max(3, repeat // 30)
        t_s = _median_time(lambda: scipy_contact(case, "DOP853", rtol=srtol, atol=srtol * 1e-6), reps)
        comparisons.append(dict(case=case.name, ours_us=ours_default["us_per_impact"],
                                ours_error=target, scipy_rtol=srtol, scipy_error=err,
                                matched=match is not None, scipy_us=t_s * 1e6,
                                speedup=t_s * 1e6 / ours_default["us_per_impact"]))
        # gravity: what it changes and what it costs (the solver always includes it)
        kw0 = dict(kw, gravity=0.0)
        res0 = contact.solve_contact(rtol=DEFAULT_RTOL, **kw0)
        t0 = _median_time(lambda: contact.solve_contact(rtol=DEFAULT_RTOL, **kw0), repeat)
        t1 = _median_time(lambda: contact.solve_contact(rtol=DEFAULT_RTOL, **kw), repeat)
        _, lam, G, _ = _scaled(case)
        gravity_rows.append(dict(case=case.name, g_theta_over_v=G,
                                 e_with=ours_default["restitution"],
                                 e_without=res0.restitution,
                                 change=abs(ours_default["restitution"] - res0.restitution),
                                 us_with=t1 * 1e6, us_without=t0 * 1e6))
    at_default = [r for r in rows if r["rtol"] == DEFAULT_RTOL]
    summary = dict(
        rtol=DEFAULT_RTOL, targets=CONTACT_TARGETS,
        max_err_restitution=max(r["err_restitution"] for r in at_default),
        median_us_per_impact=float(np.median([r["us_per_impact"] for r in at_default])),
        max_us_per_impact=max(r["us_per_impact"] for r in at_default),
        min_speedup=min(c["speedup"] for c in comparisons))
    summary["met"] = dict(
        err_restitution=summary["max_err_restitution"] <= CONTACT_TARGETS["err_restitution"],
        us_per_impact=summary["median_us_per_impact"] <= CONTACT_TARGETS["us_per_impact"],
        speedup=summary["min_speedup"] >= CONTACT_TARGETS["speedup"])
    for c in comparisons:
        c["scipy_error"] = _finite_or_none(c["scipy_error"])
    return dict(rows=rows, scipy=comparisons, gravity=gravity_rows, summary=summary)


def format_contact(result) -> str:
    """The contact benchmark as Markdown tables, with the targets and whether they are met."""
    lines = ["| case | rtol | e | lambda | err e | err tau | err pulse (L2) | energy residual | steps | method | us/impact |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in result["rows"]:
        e = "settled" if r["settled"] else f"{r['restitution']:.6f}"
        lines.append(
            f"| {r['case']} | {r['rtol']:.0e} | {e} | {r['inelasticity']:.3g} | {r['err_restitution']:.1e} | "
            f"{r['err_contact_time']:.1e} | {r['err_pulse']:.1e} | {r['energy_residual']:.1e} | "
            f"{r['steps']} | {r['method']} | {r['us_per_impact']:.1f} |")
    lines += ["", "| case | ours at rtol 1e-6 (us) | its error | solve_ivp DOP853 rtol at matched error | its error | solve_ivp (us) | speed-up |",
              "|---|---|---|---|---|---|---|"]
    for c in result["scipy"]:
        err = "not reached" if c["scipy_error"] is None else f"{c['scipy_error']:.1e}"
        lines.append(f"| {c['case']} | {c['ours_us']:.1f} | {c['ours_error']:.1e} | {c['scipy_rtol']:.0e} | "
                     f"{err} | {c['scipy_us']:.0f} | {c['speedup']:.0f}x |")
    lines += ["", "Gravity during the contact (always integrated): its effect on e and its cost, rtol 1e-6",
              "| case | g theta / v | e with gravity | e without | change of e | us with | us without |",
              "|---|---|---|---|---|---|---|"]
    for g in result["gravity"]:
        lines.append(f"| {g['case']} | {g['g_theta_over_v']:.2e} | {g['e_with']:.6f} | {g['e_without']:.6f} | "
                     f"{g['change']:.1e} | {g['us_with']:.1f} | {g['us_without']:.1f} |")
    s = result["summary"]
    t = s["targets"]
    ok = {True: "met", False: "NOT met"}
    lines += ["", f"Targets at rtol {s['rtol']:.0e}:",
              f"- restitution error, worst case: {s['max_err_restitution']:.1e} (target <= {t['err_restitution']:.0e}): "
              f"{ok[s['met']['err_restitution']]}",
              f"- time per impact, median over the cases: {s['median_us_per_impact']:.1f} us "
              f"(target <= {t['us_per_impact']:.0f} us; slowest case {s['max_us_per_impact']:.1f} us): "
              f"{ok[s['met']['us_per_impact']]}",
              f"- speed-up over solve_ivp (DOP853) at matched error, smallest: {s['min_speedup']:.0f}x "
              f"(target >= {t['speedup']:.0f}x): {ok[s['met']['speedup']]}"]
    return "\n".join(lines)


if __name__ == "__main__":  # pragma: no cover
    print(format_contact(run_contact(repeat=100)))


# ---------------------------------------------------------------------------------------
# Rendering
# ---------------------------------------------------------------------------------------
def render_scenes():
    """The render benchmark's scenes: the default preset, a thin steel sheet with
    thousands of modes, and a long series of fast small bounces."""
    from .presets import load_preset
    from .scene import Ball, Microphone, Plate, Scene

    sheet = Plate("steel", 0.0005, 0.5, 0.4)
    return [
        ("default preset (10 mm steel on 18 mm MDF, microphone)", load_preset("default")),
        ("steel sheet 0.5 mm, 0.5 x 0.4 m, 2600 modes", Scene(
            Ball("steel", 0.002), sheet, drop_height=0.05, position=(0.21, 0.17),
            listener=Microphone((0.25, 0.2, 0.3)))),
        ("small-click-on-acrylic (101 fast small bounces)", load_preset("small-click-on-acrylic")),
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


def run_render(floors=(-40.0, -60.0, -80.0, -100.0), tolerances=(1e-6, 1e-9), samplerate=48000,
               repeat=3):
    """Error of the audio against a reference render (no omissions, contact rtol 1e-10)
    against render time; the modal bank's cost per mode-sample; the real-time factor."""
    import dataclasses

    from .render import render

    rows = []
    for name, scene in render_scenes():
        ref_scene = dataclasses.replace(scene, contact=dataclasses.replace(scene.contact, rtol=1e-10))
        ref = render(ref_scene, samplerate=samplerate, normalize="none", floor_db=-200.0, fade=0.0)
        ref_audio = ref.audio.astype(float)
        ref_norm = np.linalg.norm(ref_audio)
        for tol in tolerances:
            sc = dataclasses.replace(scene, contact=dataclasses.replace(scene.contact, rtol=tol))
            for floor in floors:
                render(sc, samplerate=samplerate, normalize="none", floor_db=floor)   # warm-up
                times, banks = [], []
                for _ in range(repeat):
                    t0 = time.perf_counter()
                    r = render(sc, samplerate=samplerate, normalize="none", floor_db=floor)
                    times.append(time.perf_counter() - t0)
                    banks.append(r.settings["bank_seconds"])
                a = r.audio.astype(float)
                n = max(a.size, ref_audio.size)
                a = np.pad(a, (0, n - a.size))
                b = np.pad(ref_audio, (0, n - ref_audio.size))
                err = np.linalg.norm(a - b) / ref_norm
                t = float(np.median(times))
                ms = r.settings["mode_samples"]
                rows.append(dict(scene=name, rtol=tol, floor_db=floor,
                                 error_db=20 * math.log10(max(err, 1e-300)), error=err,
                                 lsd_db=_lsd(a, b, samplerate), seconds=t,
                                 realtime=r.duration / t, duration=r.duration,
                                 modes=r.settings["n_modes"], modes_rendered=r.settings["n_modes_rendered"],
                                 mode_samples=ms, impacts=len(r.impacts),
                                 ns_per_mode_sample=float(np.median(banks)) / max(ms, 1) * 1e9))
    return dict(samplerate=samplerate, rows=rows)


def format_render(result) -> str:
    """The render benchmark as a Markdown table."""
    lines = ["| scene | rtol | floor (dB) | error re reference (dB, rel. L2) | log-spectral distance (dB) | "
             "render (ms) | real-time factor | modes rendered / below Nyquist | mode-samples | bank (ns per mode-sample) |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for r in result["rows"]:
        lines.append(f"| {r['scene']} | {r['rtol']:.0e} | {r['floor_db']:.0f} | {r['error_db']:.1f} | "
                     f"{r['lsd_db']:.3f} | {r['seconds'] * 1e3:.1f} | {r['realtime']:.0f}x | "
                     f"{r['modes_rendered']} / {r['modes']} | {r['mode_samples']:.3g} | "
                     f"{r['ns_per_mode_sample']:.2f} |")
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
    edc = np.cumsum((x ** 2)[::-1])[::-1]
    edc_db = 10 * np.log10(edc / edc[0] + 1e-300)
    sel = (edc_db <= lo_db) & (edc_db >= hi_db)
    if sel.sum() < 10:
        return float("nan")
    t = np.nonzero(sel)[0] / fs
    slope = np.polyfit(t, edc_db[sel], 1)[0]          # dB/s, negative
    return float(-20 * math.log10(math.e) / slope)


def thesis_comparison(samplerate=48000):
    """The first tick of the thesis setup (10 mm steel ball, 10 cm, 18 mm MDF, microphone
    20 cm above the impact point) against the thesis' recordings: decay time (amplitude
    to 37 %) overall and in the 2-3 kHz band (thesis: 11-14 ms around 2-3 kHz), spectral
    centroid (thesis: a few kHz), and the e of the first impact (thesis: 0.87)."""
    from scipy.signal import butter, sosfiltfilt

    from .presets import load_preset
    from .render import render
    from .scheduler import BounceSequence, simulate_scene

    scene = load_preset("default")
    seq = simulate_scene(scene)
    first = BounceSequence(seq.impacts[:1], "max-impacts", seq.drop_height, seq.gravity)
    r = render(scene, samplerate=samplerate, normalize="none", sequence=first)
    x = r.audio.astype(float)
    fs = r.samplerate
    spec = np.abs(np.fft.rfft(x)) ** 2
    f = np.fft.rfftfreq(x.size, 1 / fs)
    centroid = float(np.sum(f * spec) / np.sum(spec))
    band = sosfiltfilt(butter(4, [2000, 3000], btype="band", fs=fs, output="sos"), x)
    return dict(restitution=seq[0].result.restitution, contact_time=seq[0].result.contact_time,
                decay_time=_decay_time(x, fs), decay_time_2_3k=_decay_time(band, fs),
                edc_decay_time=_edc_decay_time(x, fs), edc_decay_time_2_3k=_edc_decay_time(band, fs),
                centroid=centroid, peak_pa=float(np.max(np.abs(x))))


def format_thesis(c) -> str:
    return "\n".join([
        "| quantity | engine | thesis (measured) |", "|---|---|---|",
        f"| restitution of the first impact (1.4 m/s) | {c['restitution']:.3f} | 0.87 |",
        f"| contact time (us) | {c['contact_time'] * 1e6:.1f} | (~110 at 1 m/s, Fig. 2.8) |",
        f"| decay time, 2-3 kHz band, energy decay curve -5 to -25 dB (ms, amplitude to 37 %) | "
        f"{c['edc_decay_time_2_3k'] * 1e3:.1f} | 11-14 |",
        f"| decay time, 2-3 kHz band, envelope peak to 37 % (ms) | {c['decay_time_2_3k'] * 1e3:.2f} | 11-14 |",
        f"| decay time, whole tick, energy decay curve (ms) | {c['edc_decay_time'] * 1e3:.1f} | - |",
        f"| decay time, whole tick, envelope peak to 37 % (ms) | {c['decay_time'] * 1e3:.2f} | - |",
        f"| spectral centroid of the first tick (Hz) | {c['centroid']:.0f} | a few kHz |",
        f"| peak pressure at 20 cm (Pa) | {c['peak_pa']:.1f} | - |",
    ])


# ---------------------------------------------------------------------------------------
# Analysis against sounds the engine did not make
# ---------------------------------------------------------------------------------------
def synthetic_bounce(e, samplerate, *, t1=0.15, n_ticks=20, snr_db=None, seed=0):
    """A bouncing sound with a known geometric restitution, not made by the engine.

    Bounce times ``T_n = T_1 e^(n-1)`` (``T_1 = 2 v_1 / g`` from ``t1``); each tick is five
    damped sinusoids (0.6-7 kHz, decay times 4-40 ms) with amplitude proportional to the
    impact speed; white noise at ``snr_db`` (signal power over the whole file, dB).
    Returns (audio, samplerate, onsets (s)).
    """
    rng = np.random.default_rng(seed)
    fs = samplerate
    T = t1 * e ** np.arange(n_ticks)
    onsets = 0.05 + np.r_[0.0, np.cumsum(T[:-1])]
    n = int((onsets[-1] + 0.3) * fs)
    x = np.zeros(n)
    freqs = np.array([620.0, 1370.0, 2450.0, 4100.0, 6900.0])
    decays = np.array([0.040, 0.025, 0.015, 0.008, 0.004])
    amps = np.array([1.0, 0.8, 0.7, 0.5, 0.4])
    for i, t0 in enumerate(onsets):
        speed = e ** i
        k0 = int(np.ceil(t0 * fs))
        tt = np.arange(k0, min(n, k0 + int(0.25 * fs))) / fs - t0
        phase = rng.uniform(0, 2 * np.pi, freqs.size)
        tick = np.sum(amps[:, None] * np.exp(-tt[None, :] / decays[:, None])
                      * np.sin(2 * np.pi * freqs[:, None] * tt[None, :] + phase[:, None] * 0.0), axis=0)
        x[k0:k0 + tt.size] += speed * tick
    if snr_db is not None:
        p = np.mean(x ** 2)
        x = x + rng.standard_normal(n) * math.sqrt(p / 10 ** (snr_db / 10))
    return x, fs, onsets


def run_analysis(snrs=(None, 40.0, 30.0, 20.0, 10.0), restitutions=(0.6, 0.8, 0.9), seeds=10,
                 samplerate=48000):
    """Accuracy of the recovered restitution (first 8 bounces) and onsets against SNR."""
    from .analysis import analyze

    rows = []
    for snr in snrs:
        errs, onset_errs, found, missed = [], [], 0, 0
        t0 = time.perf_counter()
        for e in restitutions:
            for seed in range(seeds):
                x, fs, onsets = synthetic_bounce(e, samplerate, snr_db=snr, seed=seed)
                try:
                    a = analyze(x, fs)
                except Exception:       # no ticks found at all: counts as missed
                    missed += 8
                    continue
                got = np.array([t.time for t in a.ticks])
                for i in range(1, 9):
                    j = int(np.argmin(np.abs(got - onsets[i]))) if got.size else -1
                    if j < 0 or abs(got[j] - onsets[i]) > 1e-3:
                        missed += 1
                        continue
                    found += 1
                    onset_errs.append(got[j] - onsets[i])
                    tick = a.ticks[j]
                    if tick.restitution is not None and i >= 2:
                        errs.append(abs(tick.restitution - e) / e)
        n_files = len(restitutions) * seeds
        rows.append(dict(snr_db=snr, files=n_files, ticks_found=found, ticks_missed=missed,
                         e_error_median=float(np.median(errs)) if errs else float("nan"),
                         e_error_p95=float(np.percentile(errs, 95)) if errs else float("nan"),
                         onset_error_rms_ms=float(np.sqrt(np.mean(np.square(onset_errs)))) * 1e3
                         if onset_errs else float("nan"),
                         seconds_per_file=(time.perf_counter() - t0) / n_files))
    return dict(samplerate=samplerate, restitutions=list(restitutions), rows=rows)


def format_analysis(result) -> str:
    lines = [f"synthetic bounces: e in {result['restitutions']}, {result['rows'][0]['files']} files per "
             f"SNR, bounces 2-8 (e) and 1-8 (onsets), {result['samplerate']} Hz",
             "| SNR (dB) | ticks found / missed | e error, median | e error, 95th percentile | "
             "onset error, RMS (ms) | analysis time per file (ms) |", "|---|---|---|---|---|---|"]
    for r in result["rows"]:
        snr = "no noise" if r["snr_db"] is None else f"{r['snr_db']:.0f}"
        lines.append(f"| {snr} | {r['ticks_found']} / {r['ticks_missed']} | {r['e_error_median']:.2e} | "
                     f"{r['e_error_p95']:.2e} | {r['onset_error_rms_ms']:.3f} | {r['seconds_per_file'] * 1e3:.0f} |")
    return "\n".join(lines)
