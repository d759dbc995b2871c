"""A precomputed bounce sequence checked against the scene it is rendered with
(:func:`check_sequence`, for :func:`synth.render`'s ``sequence``)."""

from __future__ import annotations

from synth.errors import ParameterError
from synth.physics.bounces import BounceSequence

#: Relative agreement of a passed sequence's first contact with the scene's own (the
#: solver's tolerance is far tighter; another ball or plate differs by percents).
SEQUENCE_RTOL = 1e-4


def check_sequence(scene, sequence) -> BounceSequence:
    """``sequence`` as the impacts of ``scene``: a non-empty :class:`BounceSequence` whose
    contacts are ``scene``'s (its first impact solved again with the scene's ball, plate,
    impact point and contact law at the same speed gives the same contact time and peak
    force to within ``SEQUENCE_RTOL``). The impacts' times and speeds may come from
    another scene (:func:`synth.stimuli.sequences.mismatch_sequence`). With the modal plate
    in the contact an impact depends on the ringing left by the ones before, so there the
    first impact's contact law (stiffness, exponent and loss of the scene's ball and plate)
    is what is checked."""
    from synth.physics import contact

    if not isinstance(sequence, BounceSequence):
        raise ParameterError(f"sequence={sequence!r} must be a BounceSequence")
    if not len(sequence):
        raise ParameterError("sequence has no impacts: there is nothing to render")
    first = sequence[0]
    from synth.physics.plate_choice import scene_plate

    c = scene.contact
    if scene_plate(scene).plate == "modal":
        return _check_modal_sequence(scene, sequence)
    own = contact.solve_impact(
        scene.ball,
        scene.plate,
        first.speed,
        position=scene.position,
        gravity=scene.gravity,
        contact=c.law,
        rtol=c.rtol,
        **c.options(),
    )
    for name in ("contact_time", "peak_force"):
        got, want = getattr(first.result, name), getattr(own, name)
        if not abs(got - want) <= SEQUENCE_RTOL * abs(want):
            raise ParameterError(
                f"sequence: its first impact's {name} {got:.6g} is not this scene's "
                f"({want:.6g} at {first.speed:.6g} m/s): the sequence belongs to another ball, "
                f"plate or contact law; pass the scene it was computed for"
            )
    return sequence


def _check_modal_sequence(scene, sequence) -> BounceSequence:
    """:func:`check_sequence` for a scene with the modal plate in the contact: the first
    impact is one of the modal contact (:class:`~synth.physics.modal_contact.ModalImpactResult`)
    under the scene's contact law (its constants equal to ``SEQUENCE_RTOL``)."""
    from synth.physics.contact_law import contact_parameters
    from synth.physics.modal_contact import ModalImpactResult

    c = scene.contact
    result = sequence[0].result
    law = contact_parameters(scene.ball, scene.plate, c.law, **c.options())
    want = (law.stiffness, law.exponent, law.dissipation, law.viscous_time)
    got = (
        (
            result.law_stiffness,
            result.law_exponent,
            result.law_dissipation,
            result.law_viscous_time,
        )
        if isinstance(result, ModalImpactResult)
        else None
    )
    if got is None or not all(
        abs(a - b) <= SEQUENCE_RTOL * abs(b) for a, b in zip(got, want, strict=True)
    ):
        K, n, mu, A = want
        raise ParameterError(
            "sequence: its first impact is not one of this scene's modal contact (contact law "
            f"K, n, mu, A = {K:.6g}, {n:g}, {mu:g}, {A:g}): the sequence belongs to another "
            "ball, plate or contact law; pass the scene it was computed for"
        )
    return sequence
