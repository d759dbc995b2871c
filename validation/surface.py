"""MDF's contact surface fitted on the 18 mm board only (Table 3.3 contact times, the
restitution 0.76) and its predictions on the 12 and 6 mm boards."""

from __future__ import annotations

import math

from synth.constants import GRAVITY
from synth.physics import impedance
from validation.losses import gap_met
from validation.rows import (
    THESIS_ACCELEROMETER_MASS,
    THESIS_IMPACTS,
    THESIS_RESTITUTION,
    THESIS_RESTITUTION_GAPS,
    thesis_pair,
    with_accelerometer,
)


def _surface_contact(ball, plate, ratio: float, viscous_time: float, speed: float):
    """The first impact at ``speed`` (m/s) at the middle of ``plate``, the finite plate in the
    contact (:mod:`synth.physics.modal_contact`, band 4 / tau of the stored surface) and the
    plate's side of the Hertz contact at ``ratio`` times its modulus with the viscoelastic
    loss of dissipative time ``viscous_time`` (s): a trial
    :class:`~synth.physics.materials.ContactSurface`."""
    from synth.physics import modal_contact as mc
    from synth.physics.contact import solve_contact
    from synth.physics.contact_law import hertz_stiffness
    from synth.physics.materials import MDF_SURFACE

    beta = 1.0 / impedance.infinite_plate_impedance(plate)
    stored = MDF_SURFACE
    # one band per pair for every trial (the stored surface's): the modal contact solves the
    # modes of exactly its band, so a band per trial would be a mode solve per trial
    tau = solve_contact(
        mass=ball.mass,
        stiffness=hertz_stiffness(ball, plate, stored.transverse_ratio),
        admittance=beta,
        speed=speed,
        gravity=0.0,
        dissipation=stored.dissipation,
        viscous_time=stored.viscous_time,
    ).separation_time
    point = mc.modal_point(plate, plate.centre, max_frequency=mc.BAND_FACTOR / tau)
    K = hertz_stiffness(ball, plate, ratio)
    return mc.ModalContact(
        point, ball.mass, K, 1.5, GRAVITY, mc.STEPS_PER_CONTACT, viscous_time=viscous_time
    ).solve(speed)


def surface_fit(rounds: int = 4) -> dict:
    """MDF's contact surface (:class:`synth.physics.materials.ContactSurface`) fitted on the
    18 mm board only, with the finite plate in the contact at the middle of the board:

    * ``E_t / E`` on the five first-impact contact times of Table 3.3 (least squares of
      log tau), each ball with the accelerometer those measurements had on it
      (:data:`THESIS_ACCELEROMETER_MASS`);
    * the viscoelastic loss's dissipative time ``A`` (s) on the restitution 0.76 of the 10 mm
      steel ball at 1.4 m/s (section 3.2).

    The two are coupled (the loss lengthens the contact a little, the softer contact changes
    e): ``rounds`` alternations of the two one-dimensional fits, from the stored values.
    Returns the two parameters, the stored ones (:data:`synth.physics.materials.MDF_SURFACE`)
    and one row per Table 3.3 pair with the role (fit or prediction), the measured,
    thesis-model and engine contact times (the engine's with and without the accelerometer)
    and the bare ball's restitution; and the restitution rows of
    :data:`THESIS_RESTITUTION_GAPS` (engine with the stored surface, the thesis' model, the
    gap between them against the measured gap)."""
    from scipy.optimize import brentq, minimize_scalar

    from synth.physics.contact import solve_impact
    from synth.physics.materials import MDF_SURFACE

    v = math.sqrt(2.0 * GRAVITY * 0.1)
    fit_pairs = [k for k in THESIS_IMPACTS if k[1] == "18 mm"]
    pairs = {k: thesis_pair(*k) for k in THESIS_IMPACTS}
    steel = pairs["steel 10.0 mm", "18 mm"]
    e_meas = THESIS_RESTITUTION["measured"]

    def measured_contact(k, r, A):
        ball, plate = pairs[k]
        return _surface_contact(with_accelerometer(ball), plate, r, A, v)

    def tau_cost(log_ratio, A):
        r = math.exp(log_ratio)
        return sum(
            math.log(measured_contact(k, r, A).contact_time / THESIS_IMPACTS[k][0]) ** 2
            for k in fit_pairs
        )

    ratio, A = MDF_SURFACE.transverse_ratio, MDF_SURFACE.viscous_time
    for _ in range(rounds):
        A = brentq(
            lambda a: _surface_contact(*steel, ratio, a, v).restitution - e_meas,
            1e-8,
            1e-4,
            xtol=1e-12,
            rtol=1e-8,
        )
        best = minimize_scalar(
            tau_cost,
            bounds=(math.log(0.02), 0.0),
            args=(A,),
            method="bounded",
            options=dict(xatol=1e-5),
        )
        ratio = math.exp(best.x)
    stored = (MDF_SURFACE.transverse_ratio, MDF_SURFACE.viscous_time)
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
        ball, plate = thesis_pair(ball_name, board)
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
        viscous_time=A,
        stored_ratio=stored[0],
        stored_viscous_time=stored[1],
        restitution=e_fit,
        rows=rows,
        gaps=gaps,
    )


def format_surface_fit(fit: dict) -> str:
    """The tables of :func:`surface_fit` (Markdown)."""
    lines = [
        f"MDF's contact surface, fitted on the 18 mm board only (modal plate, middle): "
        f"E_t / E = {fit['ratio']:.4f} (stored {fit['stored_ratio']:.4f}), viscoelastic "
        f"A = {fit['viscous_time'] * 1e6:.4f} us (stored {fit['stored_viscous_time'] * 1e6:.4f} "
        f"us); "
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
            f"{'yes' if gap_met(g['gap'], m) else 'no'} |"
        )
    return "\n".join(lines)
