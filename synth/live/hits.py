"""What a hit or a drop on a live body is made of, checked before anything is computed: the
bounds of its arguments and the :class:`Trigger` that :meth:`synth.live.Body.hit` and
:meth:`synth.live.Body.drop` share."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from synth import checks
from synth.errors import ParameterError
from synth.physics.scene import MAX_DROP_HEIGHT, MIN_DROP_HEIGHT, Ball, Contact, HollowBall, Plate

#: Largest speed of a hit, m/s: far beyond the elastic range of every material in the table
#: (metal balls dent above a few m/s), a bound against nonsense, not a physical limit.
MAX_SPEED = 100.0
#: Largest gain of a hit or a body (linear; +80 dB: the physical calibration is set for
#: loud sources, a small panel heard from afar needs some +70 dB).
MAX_GAIN = 1e4
#: Longest time ahead of the engine's clock a hit or a drop may be scheduled, s (a slot of
#: the pending ring is held until then).
MAX_AHEAD = 60.0
#: Relative accuracy of a hit's contact solution (a drop uses a scene's default).
HIT_RTOL = 1e-6
#: The contact law of a hit or a drop given none: Hertz, or the thin-shell law.
DEFAULT_CONTACT = Contact()
SHELL_CONTACT = Contact(law="shell")


@dataclass(slots=True)
class Trigger:
    """A hit's or a drop's ball, impact point (m), gain, contact law, gravity (m/s^2) and
    start on the engine's clock (s), checked."""

    ball: Ball
    position: tuple[float, float]
    gain: float
    law: Contact
    gravity: float
    onset: float


def trigger(plate: Plate, ball, position, gain, contact, gravity, onset) -> Trigger:
    """The arguments a hit and a drop share, checked (``onset`` by the engine's clock, s)."""
    return Trigger(
        ball=check_ball(ball, plate),
        position=plate.check_position(plate.centre if position is None else position, "position"),
        gain=checks.positive_at_most("gain", gain, MAX_GAIN, "dimensionless"),
        law=check_contact(contact, ball),
        gravity=checks.positive("gravity", gravity, "m/s^2"),
        onset=onset,
    )


def check_ball(ball, plate: Plate) -> Ball:
    """``ball`` checked: a Ball whose diameter does not exceed the plate's smaller side."""
    if not isinstance(ball, Ball):
        raise ParameterError(f"ball={ball!r} must be a Ball")
    if 2.0 * ball.radius > min(plate.length, plate.width):
        raise ParameterError(
            f"ball.radius={ball.radius!r} is too large for the plate: the ball's diameter "
            f"must not exceed the plate's smaller side "
            f"{min(plate.length, plate.width)!r} (metres)"
        )
    return ball


def check_contact(contact, ball=None) -> Contact:
    """``contact`` checked: None (the ball's own law) or a Contact on the plate's impedance."""
    if contact is None:
        return SHELL_CONTACT if isinstance(ball, HollowBall) else DEFAULT_CONTACT
    if not isinstance(contact, Contact):
        raise ParameterError(f"contact={contact!r} must be None or a Contact")
    if contact.plate == "modal":
        raise ParameterError(
            f"contact.plate={contact.plate!r}: a live body solves its contacts with the "
            f"plate's impedance (contact.plate='impedance', or 'auto', which a live body "
            f"solves on the impedance plate: it carries no modes in the contact)"
        )
    return contact


def check_height(height) -> float:
    h = checks.positive_at_most("height", height, MAX_DROP_HEIGHT, "m")
    if h < MIN_DROP_HEIGHT:
        raise ParameterError(
            f"height={height!r} must be >= {MIN_DROP_HEIGHT:g} and <= {MAX_DROP_HEIGHT:g} (m)"
        )
    return h


def closed(name, value, lo, hi, unit) -> float:
    """``value`` checked: a finite float in [lo, hi] (unit)."""
    return checks.in_range(name, value, lo, hi, unit, lo_open=False, hi_open=False)


def check_int(name, value, lo, hi, unit):
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or not lo <= value <= hi:
        raise ParameterError(f"{name}={value!r} must be an integer in [{lo}, {hi}] ({unit})")
    return int(value)
