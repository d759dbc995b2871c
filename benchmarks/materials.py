"""Solid balls of the material table against published bounces (``synth bench materials``).

Each row is one published observation of a solid ball on a hard surface, with the engine's
account of the same drop (the default contact: the measured model's material surface, on the
impedance plate, docs/physics.md, "Contact losses"). Two kinds of observation are set beside the
engine:

* a force pulse's length (:class:`PulseObservation`): the engine's first impact at the
  source's drop height, or, where the source states none, at the ends of a bracket of drop
  heights (the Hertz contact time varies as ``v^(-1/5)``, so a bracket of 1 cm to 1 m spans
  a factor of 1.6);
* a count of bounces or a rate of bouncing (:class:`BounceObservation`): the engine's whole
  drop (:func:`synth.physics.bounces.simulate_bounces`), its number of impacts, the highest
  rate of its impacts (one over the shortest flight) and whether it ends before the
  scheduler's ``max_duration``.

Only what the source prints is entered as measured; the engine's ball and surface take the
table's materials (docs/materials.md) with the dimensions the source gives, and where it
gives none the row says which value was assumed. Nothing is fitted: a row that misses is
reported as a miss with its cause (docs/validation.md, "Restitution of solid balls").
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from benchmarks.common import markdown_table
from synth.constants import GRAVITY
from synth.physics.bounces import simulate_bounces
from synth.physics.contact import solve_impact
from synth.physics.scene import Ball, Plate

#: The accuracy of every impact of the table (relative, on e and the contact time).
RTOL = 1e-9
#: The contact surface of every impact: the default model's, the one closest to measurement
#: (each body's published loss factor on a table material, synth.physics.contact_law.
#: resolved_surface).
SURFACE = "auto"


@dataclass(frozen=True)
class PulseObservation:
    """A published force pulse: a solid ball of ``ball_material`` and ``radius`` (m) on
    ``surface`` (a :class:`Plate`; ``surface_name`` its description), dropped from one of
    ``drop_heights`` (m: the source's, or the bracket it lies in when the source states
    none), whose contact lasted ``contact_time`` (s) as ``measured`` says in the source's
    words."""

    ball: str
    ball_material: str
    radius: float
    surface_name: str
    surface: Plate
    source: str
    measured: str
    contact_time: float
    drop_heights: tuple[float, ...]
    note: str = ""


@dataclass(frozen=True)
class BounceObservation:
    """A published drop of a solid ball (as :class:`PulseObservation`) from ``drop_height``
    (m) that came to rest after at least ``min_bounces`` impacts, its impacts following each
    other at up to at least ``min_rate`` per second (Hz; None: not observed), as
    ``measured`` says in the source's words."""

    ball: str
    ball_material: str
    radius: float
    surface_name: str
    surface: Plate
    source: str
    measured: str
    min_bounces: int
    drop_height: float
    note: str = ""
    min_rate: float | None = None


#: G. C. McLaskey's page on the experiments of McLaskey & Glaser (2010): "a 1.58 mm diameter
#: steel ball bouncing repeatedly on a 50 mm thick steel plate ... The width of the pulse is
#: equal to the time the ball spends in contact with the plate (about 5 microseconds for this
#: case)". The page states no drop height.
MCLASKEY_PULSE = PulseObservation(
    ball="steel, 1.58 mm diameter",
    ball_material="steel",
    radius=0.79e-3,
    surface_name="steel plate, 50 mm thick",
    surface=Plate("steel", 0.05, 0.3, 0.3),
    source="G. C. McLaskey, 'Ball impact and sensor calibration project' (Cornell University, "
    "courses.cit.cornell.edu/mclaskey/impact.html), on McLaskey & Glaser, 'Hertzian impact: "
    "experimental study of the force pulse and resulting stress waves', J. Acoust. Soc. Am. "
    "128 (2010) 1087-1096",
    measured="force pulse about 5 us wide",
    contact_time=5e-6,
    drop_heights=(0.01, 1.0),
    note="the page gives no drop height: the engine is run at 1 cm and 1 m, and the row is "
    "inside when the measured width lies between the two",
)

#: The UCLA lecture demonstration of restitution: "a small steel ball is dropped on a heavy,
#: polished, slightly concave steel plate. The collisions are so elastic that the ball
#: bounces dozens of times before its energy is exhausted." The page states neither the
#: ball's size, the plate's, nor the drop height; "dozens" is taken as at least 24.
UCLA_DEMONSTRATION = BounceObservation(
    ball="steel, 10 mm diameter (assumed: 'a small steel ball')",
    ball_material="steel",
    radius=0.005,
    surface_name="steel plate, 50 mm thick (assumed: 'a heavy ... steel plate')",
    surface=Plate("steel", 0.05, 0.3, 0.3),
    source="UCLA Physics & Astronomy lecture demonstrations, '20. Coefficient of "
    "Restitution' (demoweb.physics.ucla.edu/content/20-coefficient-restitution)",
    measured="'bounces dozens of times before its energy is exhausted'",
    min_bounces=24,
    drop_height=0.3,
    note="the page gives no drop height: 0.3 m is assumed. The engine's losses for a steel "
    "pair are the table's bending-wave loss factor (1e-4) and the waves the plate carries "
    "away; the local yield that a steel ball can reach 'in a relatively low-speed "
    "collision' (R. Cross, 'The bounce of a ball', Am. J. Phys. 67 (1999) 222-227, section "
    "I) does not act here: the engine's yield of the contact (the measured model's, "
    "docs/physics.md, 'Yield of the contact') yields this hardened-steel pair above about "
    "3 m/s, and the drop lands at 2.4 m/s",
)

#: The Exploratorium's exhibit "Bouncing Ball": "The visitor pushes down a plunger and picks up
#: a steel ball bearing on a magnet. Upon release, the plunger rises and the ball drops on a
#: steel plate. ... A remarkable aspect of this exhibit is that the frequency of bounce can be
#: as high as several hundred hertz, providing the ball and plate are clean." The page states
#: neither the ball's size, the plate's, nor the drop height; "several hundred hertz" is taken
#: as at least 200 impacts per second (flights of at most 5 ms, impacts at about 25 mm/s).
EXPLORATORIUM_EXHIBIT = BounceObservation(
    ball="steel, 10 mm diameter (assumed: 'a steel ball bearing')",
    ball_material="steel",
    radius=0.005,
    surface_name="steel plate, 50 mm thick (assumed: 'a steel plate')",
    surface=Plate("steel", 0.05, 0.3, 0.3),
    source="Exploratorium, San Francisco, exhibit 'Bouncing Ball' "
    "(www.exploratorium.edu/xref/exhibits/bouncing_ball.html)",
    measured="'the frequency of bounce can be as high as several hundred hertz, providing "
    "the ball and plate are clean'",
    min_bounces=0,
    drop_height=0.3,
    min_rate=200.0,
    note="the page gives no drop height: 0.3 m is assumed, the same drop as the row above. "
    "A rate of 200 impacts per second needs flights of 5 ms, impacts at g (5 ms) / 2 = "
    "25 mm/s: 40 dB below this drop's first impact, above the scheduler's perceptual floor "
    "(an impact's kinetic energy 60 dB below the first's)",
)

#: Every row of the table, in print order.
OBSERVATIONS = (MCLASKEY_PULSE, UCLA_DEMONSTRATION, EXPLORATORIUM_EXHIBIT)


@dataclass(frozen=True)
class PulseRow:
    """The engine's first impacts for a :class:`PulseObservation`: restitution and contact
    time (s, the force pulse's length) at each of its drop heights."""

    observation: PulseObservation
    restitutions: tuple[float, ...]
    contact_times: tuple[float, ...]

    @property
    def error(self) -> float:
        """Relative distance of the measured contact time from the engine's range over the
        drop heights (dimensionless; positive when the engine's pulse is longer, 0 inside)."""
        low, high = min(self.contact_times), max(self.contact_times)
        measured = self.observation.contact_time
        if measured < low:
            return low / measured - 1.0
        if measured > high:
            return high / measured - 1.0
        return 0.0


@dataclass(frozen=True)
class BounceRow:
    """The engine's drop for a :class:`BounceObservation`: its number of impacts, the first
    impact's restitution, why it ended (``stop_reason``), its length (s), the last
    impact's kinetic energy relative to the first's (dB) and the highest rate of its impacts
    (Hz: one over the shortest time between two impacts; 0 for a single impact)."""

    observation: BounceObservation
    impacts: int
    restitution: float
    stop_reason: str
    duration: float
    last_energy_db: float
    highest_rate: float

    @property
    def came_to_rest(self) -> bool:
        """Whether the engine's ball stopped bouncing before the scheduler's limits."""
        return self.stop_reason not in ("max-duration", "max-impacts")

    @property
    def misses(self) -> tuple[str, ...]:
        """What the engine's drop does not do that the source's did (empty: it meets)."""
        o = self.observation
        found = []
        if not self.came_to_rest:
            found.append("does not come to rest")
        if self.impacts < o.min_bounces:
            found.append(f"{self.impacts} impacts, fewer than {o.min_bounces}")
        if o.min_rate is not None and self.highest_rate < o.min_rate:
            found.append(f"at most {self.highest_rate:.3g} impacts per second")
        return tuple(found)

    @property
    def meets(self) -> bool:
        """Whether the engine's drop does all the source's did: at least its number of
        impacts and its rate of impacts, and the ball comes to rest."""
        return not self.misses


def _ball(observation) -> Ball:
    return Ball(observation.ball_material, observation.radius)


def pulse_row(observation: PulseObservation, rtol: float = RTOL) -> PulseRow:
    """The engine's first impact of ``observation`` at each of its drop heights."""
    ball = _ball(observation)
    results = [
        solve_impact(
            ball,
            observation.surface,
            math.sqrt(2.0 * GRAVITY * h),
            surface=SURFACE,
            rtol=rtol,
        )
        for h in observation.drop_heights
    ]
    return PulseRow(
        observation,
        tuple(r.restitution for r in results),
        tuple(r.contact_time for r in results),
    )


def bounce_row(observation: BounceObservation) -> BounceRow:
    """The engine's whole drop of ``observation`` (the scheduler's default limits)."""
    seq = simulate_bounces(
        _ball(observation),
        observation.surface,
        drop_height=observation.drop_height,
        surface=SURFACE,
    )
    first, last = seq.impacts[0], seq.impacts[-1]
    flights = [b.time - a.time for a, b in zip(seq.impacts, seq.impacts[1:])]
    return BounceRow(
        observation,
        impacts=len(seq),
        restitution=first.result.restitution,
        stop_reason=seq.stop_reason,
        duration=seq.duration,
        last_energy_db=20.0 * math.log10(last.speed / first.speed),
        highest_rate=1.0 / min(flights) if flights else 0.0,
    )


def run_materials() -> list[PulseRow | BounceRow]:
    """Every row of :data:`OBSERVATIONS`."""
    return [
        pulse_row(o) if isinstance(o, PulseObservation) else bounce_row(o) for o in OBSERVATIONS
    ]


def _heights(heights) -> str:
    return " and ".join(f"{h:g}" for h in heights)


def _pulse_cells(row: PulseRow) -> list[str]:
    o = row.observation
    es = " / ".join(f"{e:.4f}" for e in row.restitutions)
    taus = " / ".join(f"{1e6 * t:.2f}" for t in row.contact_times)
    error = "inside" if row.error == 0.0 else f"{100.0 * row.error:+.0f} %"
    return [o.ball, o.surface_name, _heights(o.drop_heights), o.source, o.measured, es, taus, error]


def _bounce_cells(row: BounceRow) -> list[str]:
    o = row.observation
    if row.came_to_rest:
        engine = f"{row.impacts} impacts, at rest after {row.duration:.1f} s ({row.stop_reason})"
    else:
        engine = (
            f"{row.impacts} impacts, still bouncing at {row.duration:.0f} s "
            f"({row.stop_reason}), the last {-row.last_energy_db:.1f} dB below the first"
        )
    if o.min_rate is not None:
        engine += f", at most {row.highest_rate:.3g} impacts per second"
    verdict = "meets" if row.meets else "miss: " + ", ".join(row.misses)
    return [
        o.ball,
        o.surface_name,
        f"{o.drop_height:g}",
        o.source,
        o.measured,
        f"{row.restitution:.4f}",
        engine,
        verdict,
    ]


def format_materials(rows: list[PulseRow | BounceRow]) -> str:
    """The table of docs/validation.md, "Restitution of solid balls"."""
    header = [
        "ball",
        "surface",
        "drop (m)",
        "source",
        "measured (source's words)",
        "engine e (first impact)",
        "engine contact time (us) or drop",
        "error",
    ]
    lines = [_pulse_cells(r) if isinstance(r, PulseRow) else _bounce_cells(r) for r in rows]
    notes = [f"- {r.observation.ball}: {r.observation.note}." for r in rows if r.observation.note]
    return "\n".join(markdown_table(header, lines) + ([""] + notes if notes else [])) + "\n"
