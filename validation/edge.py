"""Walking in from a free edge of a thesis board: the critical distance of Table 3.3 as the
thesis' measurement resolves it.

The modal plate's restitution approaches the middle's value smoothly from a long free edge
(e at 60 mm differs from the middle's by about a tenth of a per cent for the 10 mm steel ball
on 18 mm). The thesis measured e from bounce times with a repeatability of 3 % (section 3.2:
three repeated series agree within 3 %), so its "distance from the edge where e starts to
fall" is where the fall exceeds that: the distance at which e has come to within the
repeatability of the middle's. :func:`validation.modal.modal_critical_distance` is
the model's own reading (where e stops rising); this module reads the same curve through
the measurement's resolution, and shows how the reading depends on that resolution."""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from functools import cached_property

from synth.constants import GRAVITY
from validation.rows import THESIS_IMPACTS, thesis_pair, thesis_row

#: Relative repeatability of the thesis' measured restitution (section 3.2: "three repeated
#: series agree within 3 %"): a smaller fall of e is not seen in its drops.
THESIS_RESTITUTION_REPEATABILITY = 0.03
#: Resolutions of the sensitivity table (relative fall of e below the middle's).
EDGE_RESOLUTIONS = (0.01, 0.02, 0.03, 0.05)
#: The allowance around each measured range of Table 3.3 (m) within which a predicted
#: critical distance counts as agreeing.
CRITICAL_DISTANCE_ALLOWANCE = 5e-3
#: Contact models of the study: the fitted model (the thesis scenes' default) and the modal
#: plate with the thesis' own contact (Hertz at the in-plane modulus, no contact loss).
EDGE_MODELS = {"fitted model": {"surface": "fitted"}, "modal plate": {}}


class MidlineWalk:
    """The restitution of one ball on one board at ``speed`` (m/s), first impact, at
    distances (m) from a long free edge along the board's short midline; every value is
    solved once (the modal plate with the band of the middle's contact)."""

    def __init__(self, ball, plate, speed: float, **contact_options):
        from synth.physics import modal_contact as mc

        self.plate = plate
        self.speed = speed
        self._base = mc.ModalContact.for_pair(ball, plate, None, speed=speed, **contact_options)
        self._solved: dict[float, float] = {}

    @cached_property
    def middle(self) -> float:
        """e at the middle of the board."""
        return self._base.solve(self.speed).restitution

    def restitution(self, distance: float) -> float:
        """e at ``distance`` (m) from the long edge, on the short midline."""
        from synth.physics import modal_contact as mc

        if distance not in self._solved:
            base = self._base
            point = mc.modal_point(
                self.plate,
                (0.5 * self.plate.length, distance),
                max_frequency=base.point.max_frequency,
                theory=base.point.theory,
            )
            contact = mc.ModalContact(
                point,
                base.mass,
                base.stiffness,
                base.exponent,
                base.gravity,
                base.steps_per_contact,
                base.dissipation,
                base.viscous_time,
            )
            self._solved[distance] = contact.solve(self.speed).restitution
        return self._solved[distance]

    def resolved_distances(
        self, resolutions=EDGE_RESOLUTIONS, step: float = 2e-3, tol: float = 1e-4
    ) -> dict[float, float]:
        """For each relative ``resolution``, the distance (m) from the edge at which e first
        comes within it of the middle's, ``e >= (1 - resolution) e_middle``: bracketed on a
        grid of ``step`` (m) and refined by bisection to ``tol`` (m); nan if e stays below
        it up to the midline's middle."""
        out = {}
        half_width = 0.5 * self.plate.width
        lo = 0.0
        for r in sorted(resolutions, reverse=True):  # nearest the edge first
            target = (1.0 - r) * self.middle
            if self.restitution(lo) >= target:
                out[r] = lo
                continue
            hi = lo + step
            while hi < half_width and self.restitution(hi) < target:
                lo, hi = hi, hi + step
            if hi >= half_width:
                out[r] = math.nan
                continue
            out[r] = self._bisect(lo, hi, target, tol)
        return out

    def _bisect(self, lo: float, hi: float, target: float, tol: float) -> float:
        """The crossing of ``target`` by e between ``lo`` (below it) and ``hi`` (m)."""
        while hi - lo > tol:
            mid = 0.5 * (lo + hi)
            if self.restitution(mid) < target:
                lo = mid
            else:
                hi = mid
        return 0.5 * (lo + hi)


@dataclass(frozen=True)
class EdgeReading:
    """One ball/board pair of Table 3.3 under one contact model: the measured critical
    distance (m, range) and, per relative resolution of e, the engine's (m)."""

    model: str
    ball: str
    board: str
    measured: tuple[float, float]
    distances: dict[float, float]

    @classmethod
    def from_json(cls, data: dict) -> EdgeReading:
        """The reading :func:`edge_study_json` wrote as ``data``."""
        distances = {float(r): v for r, v in data["distances"].items()}
        return cls(data["model"], data["ball"], data["board"], tuple(data["measured"]), distances)

    def within_allowance(self, resolution: float) -> bool:
        """Whether the reading at ``resolution`` lies inside the measured range widened by
        :data:`CRITICAL_DISTANCE_ALLOWANCE` on each side."""
        lo, hi = self.measured
        d = self.distances[resolution]
        return lo - CRITICAL_DISTANCE_ALLOWANCE <= d <= hi + CRITICAL_DISTANCE_ALLOWANCE


def edge_study(pairs=None, models=EDGE_MODELS, resolutions=EDGE_RESOLUTIONS) -> list:
    """The critical distances of the ball/board ``pairs`` of Table 3.3 (default: all nine),
    first impact from 10 cm, under each contact model of ``models`` (name -> options of
    :class:`synth.physics.modal_contact.ModalContact`), read at each resolution: a list of
    :class:`EdgeReading`."""
    from synth.physics.contact import solve_impact

    v1 = math.sqrt(2.0 * GRAVITY * 0.1)
    keys = list(THESIS_IMPACTS) if pairs is None else list(pairs)
    # widest band (shortest contact) first on each board: the modes' cache serves the others
    solve_order = sorted(
        keys, key=lambda k: solve_impact(*thesis_pair(*k), v1, rtol=1e-6).contact_time
    )
    readings = []
    for model, options in models.items():
        for ball_name, board_name in solve_order:
            walk = MidlineWalk(*thesis_pair(ball_name, board_name), v1, **options)
            readings.append(
                EdgeReading(
                    model,
                    ball_name,
                    board_name,
                    THESIS_IMPACTS[ball_name, board_name][2],
                    walk.resolved_distances(resolutions),
                )
            )
    place = {(m, *k): i for i, (m, k) in enumerate((m, k) for m in models for k in keys)}
    return sorted(readings, key=lambda r: place[r.model, r.ball, r.board])


def thesis_edge_rows(readings: list) -> list:
    """The thesis rows of the critical distances read at the thesis' repeatability."""
    from validation.rows import THESIS_BOARDS

    r = THESIS_RESTITUTION_REPEATABILITY
    rows = []
    for reading in readings:
        tau_meas = THESIS_IMPACTS[reading.ball, reading.board][0]
        rows.append(
            thesis_row(
                f"critical distance as measured (e {100 * r:.0f} % below the middle's), "
                f"{reading.model}, {reading.ball} on {reading.board}",
                "m",
                reading.distances[r],
                0.5 * tau_meas * THESIS_BOARDS[reading.board][4],
                reading.measured,
                f"engine: where e comes within {100 * r:.0f} % (the measurements' "
                "repeatability) of the middle's; model: the thesis' tau c / 2",
            )
        )
    return rows


def edge_study_json(readings: list) -> list:
    """``readings`` as plain data (resolutions as strings, for JSON)."""
    out = []
    for reading in readings:
        d = asdict(reading)
        d["distances"] = {f"{r:g}": v for r, v in reading.distances.items()}
        out.append(d)
    return out


def format_edge_study(data: list) -> str:
    """The sensitivity table (Markdown) of the readings :func:`edge_study_json` wrote as
    ``data``: each pair's critical distance per resolution and model, and how many pairs lie
    within the allowance of their measured ranges."""
    readings = [EdgeReading.from_json(d) for d in data]
    resolutions = sorted(readings[0].distances)
    head = " | ".join(f"{100 * r:g} %" for r in resolutions)
    lines = [
        "Critical distance read through the measurement's resolution (first impact from 10 cm, "
        "bare ball): the distance from a long free edge at which e comes within the resolution "
        f"of the middle's; the thesis' repeatability is {100 * THESIS_RESTITUTION_REPEATABILITY:g}"
        " %.",
        "",
        f"| ball on board | model | measured (mm) | {head} |",
        "|---|---|---|" + "---|" * len(resolutions),
    ]
    for reading in readings:
        lo, hi = reading.measured
        cells = " | ".join(f"{1e3 * reading.distances[r]:.1f}" for r in resolutions)
        lines.append(
            f"| {reading.ball} on {reading.board} | {reading.model} | "
            f"{1e3 * lo:.0f}-{1e3 * hi:.0f} | {cells} |"
        )
    for model in dict.fromkeys(r.model for r in readings):
        mine = [r for r in readings if r.model == model]
        counts = " | ".join(
            f"{sum(r.within_allowance(res) for r in mine)} / {len(mine)}" for res in resolutions
        )
        lines.append(
            f"| pairs within the range +- {1e3 * CRITICAL_DISTANCE_ALLOWANCE:g} mm | {model} | | "
            f"{counts} |"
        )
    return "\n".join(lines)
