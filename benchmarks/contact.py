"""``synth bench contact``: the contact solver's error in e and the force pulse against its
time per impact, at several tolerances, against SciPy's DOP853 (and the modal plate's cost)."""

from __future__ import annotations

import dataclasses
import math
import time
from dataclasses import dataclass

import numpy as np

from benchmarks.common import median_time, target_verdict
from synth.constants import DEFAULT_FLOOR_DB, DEFAULT_MAX_IMPACTS, GRAVITY
from synth.physics import contact, impedance
from synth.physics import contact_law as laws
from synth.physics.scene import Ball, Plate
from validation import thesis_pair


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
    viscous_time: float = 0.0  # s

    def solver_arguments(self) -> dict:
        """The case as keyword arguments of :func:`synth.physics.contact.solve_contact`."""
        return dict(
            mass=self.mass,
            stiffness=self.stiffness,
            admittance=self.admittance,
            speed=self.speed,
            gravity=self.gravity,
            exponent=self.exponent,
            dissipation=self.dissipation,
            viscous_time=self.viscous_time,
        )


def _case(name, ball, plate, speed, gravity=GRAVITY, law="hertz", **kw):
    c = laws.contact_parameters(ball, plate, law, **kw)
    beta = 1.0 / impedance.infinite_plate_impedance(plate)
    return ContactCase(
        name, ball.mass, c.stiffness, beta, speed, gravity, c.exponent, c.dissipation,
        c.viscous_time,
    )  # fmt: skip


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
            law="hunt-crossley",
            dissipation=0.2,
        ),
    ]


def _scaled(case):
    """(theta, lam, G, c, b): the scales and constants of the dimensionless equations."""
    v0 = case.speed
    n = case.exponent
    theta = (case.mass / (case.stiffness * v0 ** (n - 1.0))) ** (1.0 / (n + 1.0))
    lam = case.admittance * case.mass / theta
    G = case.gravity * theta / v0
    return theta, lam, G, case.dissipation * v0, 1.5 * case.viscous_time / theta


def _reference_force(x, w, lam, n, c, b):
    """The dimensionless force of the equations (synth/physics/contact_kernels/equations.py),
    written again with numpy for the reference: ``max(0, x^n + (c x^n + b x^(1/2)) x')``
    solved for f (x' = w - lam f); x and w arrays."""
    x = np.maximum(x, 0.0)
    a = x**n
    d = c * a + b * np.sqrt(x)
    return np.maximum(0.0, (a + d * w) / (1.0 + lam * d))


@dataclass(frozen=True)
class ScaledEquations:
    """The dimensionless impact equations of a case (x the penetration over theta, w its rate
    over v0, s the time over theta), written with plain Python for an independent reference."""

    lam: float
    G: float
    c: float
    b: float
    n: float

    @classmethod
    def of(cls, case: ContactCase) -> ScaledEquations:
        _, lam, G, c, b = _scaled(case)
        return cls(lam, G, c, b, case.exponent)

    @property
    def lossy(self) -> bool:
        return self.c != 0.0 or self.b != 0.0

    def force(self, x, w) -> float:
        if x <= 0.0:
            return 0.0
        if not self.lossy:
            return x**self.n
        return float(_reference_force(x, w, self.lam, self.n, self.c, self.b))

    def rhs(self, s, y):
        f = self.force(y[0], y[1])
        return [y[1] - self.lam * f, self.G - f]

    def jacobian(self, s, y):
        x, w = y
        if x <= 0.0:
            return [[0.0, 1.0], [0.0, 0.0]]
        n, c, b, lam = self.n, self.c, self.b, self.lam
        a = x**n
        da = n * a / x
        r = math.sqrt(x)
        d = c * a + b * r  # damping, and its derivative in x
        dd = c * da + 0.5 * b / r
        den = 1.0 + lam * d
        f = (a + d * w) / den
        if f > 0.0:
            fx, fw = (da + dd * w - f * lam * dd) / den, d / den
        else:
            fx, fw = 0.0, 0.0
        return [[-lam * fx, 1.0 - lam * fw], [-fx, -fw]]

    def settle_energy(self, s, y) -> float:
        """The energy above the settled state's: it falls through 0 when the ball settles."""
        x, w = y
        n, lam, G = self.n, self.lam, self.G
        u = lam * G - w
        W = 0.5 * u * u + (x ** (n + 1) / (n + 1) - G * x if x > 0 else 0.0)
        return W - 0.5 * (lam * G) ** 2

    def unclipped_force(self, s, y) -> float:
        """The lossy force's sign before its clip at 0 (the pulse's end)."""
        x, w = y
        return x**self.n * (1.0 + self.c * w) + self.b * math.sqrt(x) * w if x > 0.0 else x

    def start(self) -> tuple[float, list]:
        """A start a hair after first touch, so that the x = 0 event does not fire at s = 0:
        the first terms of the series solution, x = s + G s^2/2, w = 1 + G s; the viscoelastic
        force b s^(1/2) adds - 2/3 b s^(3/2) to w and - 2/3 lam b s^(3/2) to x."""
        s0 = 1e-10
        v = 2.0 / 3.0 * self.b * s0**1.5
        return s0, [s0 + 0.5 * self.G * s0 * s0 - self.lam * v, 1.0 + self.G * s0 - v]


def _events(eq: ScaledEquations) -> list:
    """solve_ivp's events: the separation (x = 0), the settling when the ball can settle
    (gravity with a loss), the lossy force's end."""

    def end(s, y):
        return y[0]

    end.terminal = True
    end.direction = -1

    def settle(s, y):
        return eq.settle_energy(s, y)

    settle.terminal = True
    settle.direction = -1

    def force_end(s, y):
        return eq.unclipped_force(s, y)

    force_end.direction = -1
    events = [end, settle] if (eq.G > 0 and (eq.lam > 0 or eq.lossy)) else [end]
    return events + [force_end] if eq.lossy else events


@dataclass(frozen=True)
class ReferenceImpact:
    """An impact integrated by scipy: restitution, contact time (s), the dense solution
    (dimensionless time and state) and the time scale theta (s)."""

    restitution: float
    contact_time: float
    solution: object
    theta: float


def scipy_contact(
    case: ContactCase, method: str = "Radau", rtol: float = 1e-12, atol: float = 1e-15
) -> ReferenceImpact:
    """The same impact integrated by ``scipy.integrate.solve_ivp`` (an independent
    implementation of the same dimensionless equations), for reference and comparison.

    The contact time as :class:`synth.physics.contact.ImpactResult`'s, the force pulse's
    length (with a loss the last downward zero of the force, before the penetration's).
    """
    from scipy.integrate import solve_ivp

    eq = ScaledEquations.of(case)
    kw = dict(jac=eq.jacobian) if method in ("Radau", "BDF", "LSODA") else {}
    s0, y0 = eq.start()
    sol = solve_ivp(
        eq.rhs,
        (s0, 1e9),
        y0,
        method=method,
        rtol=rtol,
        atol=atol,
        events=_events(eq),
        dense_output=True,
        **kw,
    )
    if sol.t_events[0].size:
        s_end = sol.t_events[0][0]
        e = max(0.0, -sol.y_events[0][0][1])
        if eq.lossy and sol.t_events[-1].size:
            s_end = min(s_end, sol.t_events[-1][-1])  # the force pulse's end
    else:
        s_end = sol.t_events[1][0] if len(sol.t_events) > 1 and sol.t_events[1].size else sol.t[-1]
        e = 0.0
    theta = _scaled(case)[0]
    return ReferenceImpact(e, s_end * theta, sol, theta)


def _pulse_error(res, sol, theta, case):
    """Relative L2 error of the force pulse against the reference's dense output."""
    _, lam, G, c, b = _scaled(case)
    n = case.exponent
    s = res.time / theta
    y = sol.sol(np.clip(s, sol.t[0], sol.t[-1]))
    f = _reference_force(y[0], y[1], lam, n, c, b)
    f_ref = f * case.mass * case.speed / theta
    return float(np.linalg.norm(res.force - f_ref) / np.linalg.norm(f_ref))


#: The contact solver's targets at the default rtol: the restitution error, the
#: median time of one impact (us), and the speed-up over scipy's solve_ivp at equal error.
CONTACT_TARGETS = dict(err_restitution=1e-6, us_per_impact=20.0, speedup=100.0, drop_us=5.0)
#: The drops whose impacts are timed through the compiled series and one call each
#: (:func:`run_drop_contacts`): presets on the plate's impedance.
DROP_PRESETS = ("default", "small-click-on-acrylic")
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
        ref = scipy_contact(case)
        e_ref, tau_ref = ref.restitution, ref.contact_time
        kw = case.solver_arguments()
        ours_default = None
        for tol in tolerances:
            res = contact.solve_contact(rtol=tol, **kw)
            t = median_time(lambda: contact.solve_contact(rtol=tol, **kw), repeat)
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
                err_pulse=_pulse_error(res, ref.solution, ref.theta, case),
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
            s = scipy_contact(case, "DOP853", rtol=srtol, atol=srtol * 1e-6)
            err = max(
                abs(s.restitution - e_ref) / max(e_ref, 1e-300)
                if e_ref > 0
                else abs(s.restitution),
                abs(s.contact_time - tau_ref) / tau_ref,
            )
            if err <= target:
                match = (srtol, err)
                break
        srtol, err = match if match is not None else (1e-13, None)
        reps = max(3, repeat // 30)
        t_s = median_time(
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
        t0 = median_time(lambda: contact.solve_contact(rtol=DEFAULT_RTOL, **kw0), repeat)
        t1 = median_time(lambda: contact.solve_contact(rtol=DEFAULT_RTOL, **kw), repeat)
        _, lam, G, _, _ = _scaled(case)
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
    drops = run_drop_contacts(repeat=max(3, repeat // 15))
    summary["max_drop_us_per_impact"] = max(
        d["batch_us"] for d in drops if d["rtol"] == DEFAULT_RTOL
    )
    summary["met"]["drop_us"] = bool(
        summary["max_drop_us_per_impact"] <= CONTACT_TARGETS["drop_us"]
    )
    out = dict(rows=rows, scipy=comparisons, gravity=gravity_rows, drops=drops, summary=summary)
    if modal:
        out["modal"] = run_modal_contact(repeat=max(3, repeat // 15))
    return out


def run_drop_contacts(repeat: int = 20, presets=DROP_PRESETS) -> list[dict]:
    """The impacts of each preset's drop (on the plate's impedance, its contact law, the
    bounce series' default floor and limits) solved through the compiled series
    (:meth:`~synth.physics.contact.ContactSolver.solve_drop`) and one call each
    (:meth:`~synth.physics.contact.ContactSolver.solve`, at the series' speeds): the time per
    impact of each (median of ``repeat``), and whether both give the same impacts (e and
    tau equal to the last bit: the same error); at the solver's default rtol
    (:data:`DEFAULT_RTOL`, that of the target) and at the preset's own."""
    from synth.io.presets import load_preset

    rows = []
    for name in presets:
        scene = load_preset(name)
        for rtol in sorted({DEFAULT_RTOL, scene.contact.rtol}, reverse=True):
            rows.append(_drop_row(name, scene, rtol, repeat))
    return rows


def _drop_row(name, scene, rtol, repeat) -> dict:
    """:func:`run_drop_contacts`' figures of one preset's ``scene`` at ``rtol``."""
    c = scene.contact
    solver = contact.ContactSolver.for_pair(
        scene.ball, scene.plate, gravity=scene.gravity, law=c.law, rtol=rtol, **c.options()
    )
    g, h0 = scene.gravity, scene.drop_height
    first = (math.sqrt(2.0 * g * h0), math.sqrt(2.0 * h0 / g))
    rules = dict(
        position=scene.position,
        energy_floor=10.0 ** (DEFAULT_FLOOR_DB / 10.0),
        max_duration=60.0,
        max_impacts=DEFAULT_MAX_IMPACTS,
    )
    drop = solver.solve_drop(*first, **rules)
    count = len(drop.results)

    def one_call_each(speeds=drop.speeds):
        return [solver.solve(v, position=scene.position) for v in speeds]

    same = all(
        a.restitution == b.restitution and a.contact_time == b.contact_time
        for a, b in zip(drop.results, one_call_each())
    )
    return dict(
        preset=name,
        rtol=rtol,
        impacts=count,
        end=drop.end,
        same=bool(same),
        batch_us=median_time(lambda: solver.solve_drop(*first, **rules), repeat) / count * 1e6,
        single_us=median_time(one_call_each, repeat) / count * 1e6,
    )


def format_drop_contacts(rows) -> list[str]:
    """The lines of :func:`run_drop_contacts`' table."""
    lines = [
        "",
        "The impacts of a drop: one compiled call for the series against one call per "
        "impact, time per impact",
        "| preset | rtol | impacts | end | same impacts | series in one call (us) | "
        "one call each (us) |",
        "|---|---|---|---|---|---|---|",
    ]
    for d in rows:
        lines.append(
            f"| {d['preset']} | {d['rtol']:.0e} | {d['impacts']} | {d['end']} | "
            f"{'yes' if d['same'] else 'NO'} | "
            f"{d['batch_us']:.1f} | {d['single_us']:.1f} |"
        )
    return lines


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
    if "drops" in result:
        lines += format_drop_contacts(result["drops"])
    s = result["summary"]
    t = s["targets"]
    lines += [
        "",
        f"Targets at rtol {s['rtol']:.0e}:",
        f"- restitution error, worst case: {s['max_err_restitution']:.1e} (target <= {t['err_restitution']:.0e}): "
        f"{target_verdict(s['met']['err_restitution'])}",
        f"- time per impact, median over the cases: {s['median_us_per_impact']:.1f} us "
        f"(target <= {t['us_per_impact']:.0f} us; slowest case {s['max_us_per_impact']:.1f} us): "
        f"{target_verdict(s['met']['us_per_impact'])}",
        f"- speed-up over solve_ivp (DOP853) at matched error, smallest: {s['min_speedup']:.0f}x "
        f"(target >= {t['speedup']:.0f}x): {target_verdict(s['met']['speedup'])}",
    ]
    if "max_drop_us_per_impact" in s:
        lines.append(
            f"- contacts in a drop (one compiled call, rtol {s['rtol']:.0e}), slowest preset: "
            f"{s['max_drop_us_per_impact']:.1f} us per impact (target <= {t['drop_us']:.0f} us): "
            f"{target_verdict(s['met']['drop_us'])}"
        )
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

    The reference at each point is the modal plate at the widest band and 8192 steps; the
    band error left in it is of the size of its difference from the next band's
    (``reference_spread``, printed under the table: the residual carries the infinite plate's
    modes above the band, so the band error has no fixed order to extrapolate by,
    tests/test_modal_contact.py). Times are medians of
    ``repeat`` solves of a contact built once (the build, modes from the cache and shapes at
    the point, is timed apart)."""
    from synth.physics import modal_contact as mc
    from synth.physics.contact import solve_impact

    ball, plate = thesis_pair("steel 10.0 mm", "18 mm")
    v = math.sqrt(2.0 * GRAVITY * 0.1)
    tau = solve_impact(ball, plate, v, rtol=1e-9).contact_time
    chosen = (
        MODAL_CONTACT_POINTS if points is None else {k: MODAL_CONTACT_POINTS[k] for k in points}
    )
    rows = []
    for name, pos in chosen.items():

        def modal(band, steps):
            t0 = time.perf_counter()
            c = mc.ModalContact.for_pair(ball, plate, pos, max_frequency=band / tau)
            c = dataclasses.replace(c, steps_per_contact=steps)
            build = time.perf_counter() - t0
            return c, build

        wide, narrow = MODAL_BANDS[-1], MODAL_BANDS[-2]
        e_w = modal(wide, 8192)[0].solve(v).restitution
        e_n = modal(narrow, 8192)[0].solve(v).restitution
        ref = e_w
        imp = solve_impact(ball, plate, v, position=pos, rtol=1e-6)
        t_imp = median_time(lambda: solve_impact(ball, plate, v, position=pos), repeat)
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
                reference_spread=abs(e_w - e_n),
            )
        )
        for band in MODAL_BANDS:
            for steps in MODAL_STEPS:
                c, build = modal(band, steps)
                r = c.solve(v)
                t = median_time(lambda: c.solve(v), repeat)
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
        "modal plate at its widest band and finest step, and time per impact",
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
    spreads = ", ".join(
        f"{r['point']} {r['reference_spread']:.1e}" for r in rows if "reference_spread" in r
    )
    lines += [
        "",
        f"Reference: the modal plate at the widest band and 8192 steps; its difference from the "
        f"next band's, the size of the band error left in it: {spreads}.",
    ]
    return "\n".join(lines)


if __name__ == "__main__":  # pragma: no cover
    print(format_contact(run_contact(repeat=100)))
