"""Perception stimuli: bouncing sounds whose parameters are varied on purpose while the rest
stays physical (the thesis, section 5.2): :func:`scaled_sequence` (restitution changed by
``1 - e' = k (1 - e)``, each impact still solved at its own speed) and
:func:`mismatch_sequence` (one scene's impact times and speeds with another's ticks).
"""

from __future__ import annotations

from dataclasses import dataclass

from synth import checks
from synth.errors import ParameterError
from synth.physics import contact
from synth.physics.bounces import BounceSequence, Impact, simulate_scene
from synth.physics.contact import ImpactResult
from synth.physics.scene import Scene


@dataclass(frozen=True)
class RestitutionScaling:
    """The rebound rule ``1 - e' = k (1 - e)`` of the thesis (section 5.2.2) for
    :func:`synth.physics.bounces.simulate_bounces`: ``scale`` ``k >= 0`` (dimensionless),
    1 physical, < 1 bouncier, > 1 deader; where ``e' <= 0`` the ball stays on the plate."""

    scale: float

    def __post_init__(self):
        object.__setattr__(
            self, "scale", checks.nonnegative("restitution_scale", self.scale, "dimensionless")
        )

    def __call__(self, result: ImpactResult, speed: float) -> float:
        """``e'`` from the impact's physical restitution (``speed``, m/s, unused)."""
        return 1.0 - self.scale * (1.0 - result.restitution)


def _rebound_rule(restitution_scale: float) -> RestitutionScaling | None:
    """The rule for ``k``; None (the physical rebound, bit for bit) for ``k = 1``."""
    rule = RestitutionScaling(restitution_scale)
    return None if rule.scale == 1.0 else rule


def scaled_sequence(scene: Scene, restitution_scale: float, **options) -> BounceSequence:
    """The bounce sequence of ``scene`` with ``1 - e' = k (1 - e)`` for every tick
    (:class:`RestitutionScaling`); ``options`` as in :func:`synth.simulate_bounces`."""
    return simulate_scene(scene, rebound=_rebound_rule(restitution_scale), **options)


def mismatch_sequence(
    timing_scene: Scene, spectrum_scene: Scene, *, restitution_scale: float = 1.0, **options
) -> BounceSequence:
    """Impact times (s from release) and speeds (m/s) of ``timing_scene`` (its restitution
    scaled by ``restitution_scale``), each contact solved with ``spectrum_scene``'s ball,
    plate, point, gravity and contact model at that speed; ``options`` go to the timing
    scene's :func:`synth.simulate_bounces`."""
    for name, s in (("timing_scene", timing_scene), ("spectrum_scene", spectrum_scene)):
        if not isinstance(s, Scene):
            raise ParameterError(f"{name}={s!r} must be a Scene")
    timing = simulate_scene(timing_scene, rebound=_rebound_rule(restitution_scale), **options)
    s, c = spectrum_scene, spectrum_scene.contact
    solver = contact.ContactSolver.for_pair(
        s.ball, s.plate, gravity=s.gravity, law=c.law, rtol=c.rtol, **c.options()
    )
    impacts = [
        Impact(i.index, i.time, i.speed, solver.solve(i.speed, position=s.position), i.restitution)
        for i in timing
    ]
    return BounceSequence(tuple(impacts), timing.stop_reason, timing.drop_height, timing.gravity)
