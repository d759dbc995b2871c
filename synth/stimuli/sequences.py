"""Perception stimuli (thesis section 5.2): bouncing sounds whose parameters are varied on
purpose while the rest stays physical.

* :func:`scaled_sequence`: restitution changed by the thesis' rule ``1 - e' = k (1 - e)`` for
  every tick, each impact still solved physically at its own speed (the tick keeps the
  physics of its spectrum; only the timing and the speeds follow ``e'``).
* :func:`mismatch_sequence`: the timing (impact times and speeds) of one scene with the
  ticks of another: each impact of the timing scene is solved again with the other scene's
  ball, plate and contact at the same speed and time (the "physical mismatch" stimuli the
  thesis proposes: a large ball's rhythm with a small ball's clicks, and so on).

Render either with :func:`synth.sound.render.render` (``sequence=``) using the scene whose plate
and listener should be heard.
"""

from __future__ import annotations

from synth.physics import contact
from synth.errors import ParameterError
from synth.physics.scene import Scene
from synth.physics.bounces import BounceSequence, Impact, simulate_scene


def scaled_sequence(scene, restitution_scale, **options) -> BounceSequence:
    """The bounce sequence of ``scene`` with ``1 - e' = k (1 - e)`` for every tick.

    ``restitution_scale`` is ``k >= 0`` (dimensionless); ``options`` as in
    :func:`synth.simulate_bounces`.
    """
    return simulate_scene(scene, restitution_scale=restitution_scale, **options)


def mismatch_sequence(timing_scene, spectrum_scene, **options) -> BounceSequence:
    """Impact times and speeds of ``timing_scene``, contacts of ``spectrum_scene``.

    Each impact keeps its time (s from release) and speed (m/s) from ``timing_scene``;
    its contact (pulse, contact time) is solved with ``spectrum_scene``'s ball, plate,
    impact point, gravity and contact model at that speed. ``options`` go to the
    timing scene's :func:`synth.simulate_bounces`.
    """
    for name, s in (("timing_scene", timing_scene), ("spectrum_scene", spectrum_scene)):
        if not isinstance(s, Scene):
            raise ParameterError(f"{name}={s!r} must be a Scene")
    timing = simulate_scene(timing_scene, **options)
    c = spectrum_scene.contact
    impacts = []
    for imp in timing:
        res = contact.solve_impact(spectrum_scene.ball, spectrum_scene.plate, imp.speed,
                                   position=spectrum_scene.position, gravity=spectrum_scene.gravity,
                                   contact=c.law, rtol=c.rtol, **c.options())
        impacts.append(Impact(imp.index, imp.time, imp.speed, res, imp.restitution))
    return BounceSequence(tuple(impacts), timing.stop_reason, timing.drop_height, timing.gravity)
