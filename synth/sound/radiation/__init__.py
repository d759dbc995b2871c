"""Sound radiated by plate modes to a microphone: the Rayleigh integral.

The plate ``[0, a] x [0, b]`` lies in the plane ``z = 0`` of an infinite rigid
baffle, air on the side ``z > 0``. When its normal surface velocity is one mode,
``v(xs, t) = phi_k(xs) u(t)`` with ``u(t) = exp(s t)``, the pressure at the
listener ``xL = (x, y, z)`` is ``p(xL, t) = H_k(s) exp(s t)`` with the exact
transfer function of the Rayleigh integral (docs/physics.md, "Radiation")::

    H_k(s) = (rho s / (2 pi)) Int_plate phi_k(xs) exp(-s R / c) / R dA,   R = |xL - xs|

(``rho s u`` is the surface acceleration; the integral is linear and
time-invariant, so an exponential input returns the same exponential times
``H_k(s)``, the propagation delay included). ``s`` may be any complex number: a
damped mode ringing as ``exp(p_k t)``, ``p_k = -sigma_k + i omega_dk``, takes
``s = p_k`` (the analytic continuation of the same formula). Units: ``H`` is in
pascals per metre-per-second of the modal velocity ``u`` (Pa s/m).

For synthesis with one pure delay per listener, the gain can be returned with a
reference delay factored out, ``H_k(s) exp(+s R0 / c)``, where ``R0`` is the
distance from the listener to a reference point (for instance the impact point,
:func:`distance`); the pressure is then that gain applied ``R0 / c`` seconds
(:func:`delay`) later.
Rules (one module each)
-----------------------
- :mod:`~synth.sound.radiation.rectangle`: :func:`rayleigh_gains`, tensor Gauss-Legendre
  panels along x and y, for any shapes;
- :mod:`~synth.sound.radiation.polar`: :func:`separable_gains`, polar coordinates about
  the microphone, for shapes ``X_i(x) Y_j(y)`` (the simply supported plate);
- :mod:`~synth.sound.radiation.summed`: :func:`summed_gains`, the same for sums of such
  products (the free and clamped plates);
- :mod:`~synth.sound.radiation.boundary`: the dynamic edge effect modes of large free and
  clamped plates as integrals over the plate's boundary (Green's second identity);
- :mod:`~synth.sound.radiation.refinement`: the convergence test of every rule;
  :mod:`~synth.sound.radiation.common`: their result, checks and numba kernel;
  :mod:`~synth.sound.radiation.cache`: the gains kept in memory and on disk.

:func:`plate_gains` computes the gains of a :class:`synth.physics.modes.Modes`, cached: by
the rectangle rule, unless its work (modes times points) exceeds ``5e7`` for separable
shapes (then the polar rule) or :data:`SUMMED_RULE_WORK` (``5e8``, above every preset's)
for free and clamped plates (then the summed polar rule). A plate with dynamic edge effect
modes (past the Ritz crossover of :func:`synth.physics.modes.modes`) whose rectangle-rule work
exceeds :data:`BOUNDARY_RULE_WORK` on a plate of more than :data:`BOUNDARY_RULE_SIZE`
wavelengths (or whose rectangle rule would exceed ``max_points``) takes the boundary rule for
those and the rectangle rule for its Ritz modes; otherwise the rectangle rule band by band of
wavenumber (:data:`BAND_RATIO`:
each band's grid follows its own fastest mode's wavelength, the Ritz modes one band), the
edge effect modes' shapes formed from their factor tables inside the sums
(:func:`~synth.sound.radiation.rectangle.product_gains`).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from synth import checks
from synth.constants import AIR_DENSITY, SOUND_SPEED
from synth.errors import ParameterError
from synth.physics.modes import Modes
from synth.sound.radiation.boundary import boundary_rule
from synth.sound.radiation.cache import (
    CACHE,
    cache_info,
    clear_memory_cache,
    frozen,
    gains_key,
    load_gains,
    save_gains,
)
from synth.sound.radiation.common import (
    MAX_ORDER,
    REFINE,
    RadiationResult,
    check_listener,
    check_poles,
    check_settings,
    half_phase,
)
from synth.sound.radiation.polar import separable_gains
from synth.sound.radiation.rectangle import ProductFactors, product_gains, rayleigh_gains
from synth.sound.radiation.refinement import warn_unconverged
from synth.sound.radiation.summed import summed_gains

__all__ = [
    "RadiationResult",
    "rayleigh_gains",
    "separable_gains",
    "summed_gains",
    "plate_gains",
    "delay",
    "distance",
    "cache_info",
    "clear_memory_cache",
]

#: Most points of one rule of :func:`plate_gains` unless the caller gives ``max_points``.
DEFAULT_MAX_POINTS = 4_000_000

# Work of the rectangle rule (modes times points of its first rule, estimated from its
# longest panels) above which a plate
# with separable shapes takes the polar rule of separable_gains. Below it the rectangle
# rule takes at most a few seconds and is kept: its gains (the polar rule's agree to
# tol, not to the last bit) are those the presets' recorded renders were made with
# (the largest simply supported preset, 550 modes at 48 kHz, is 3.6e7).
POLAR_WORK = 5e7


def _use_separable(modes, size, listener, q_s, kb, c, tol):
    """The modes' :class:`~synth.physics.modes.SeparableShapes` if :func:`plate_gains`
    should use :func:`separable_gains`, else None."""
    shapes = modes.separable()
    if shapes is None or q_s.size == 0:
        return None
    return shapes if _rectangle_work(size, q_s, kb, c, tol) > POLAR_WORK else None


#: Rectangle-rule work (modes times points, as for ``POLAR_WORK``) above which a free or
#: clamped plate takes the polar rule of :func:`summed_gains`. Above every preset's (at
#: most 3.4e8, a free wooden table at 48 kHz: their recorded renders were made with the
#: rectangle rule), below the default board's at 192 kHz (7e8). ``math.inf``: never.
SUMMED_RULE_WORK = 5e8


#: Rectangle-rule work (as for ``POLAR_WORK``) above which a plate with dynamic edge effect
#: modes takes the boundary rule for them. Its cost grows with the plate's diameter times
#: the wavenumber rather than the area times its square, but with a larger constant: below
#: this work the banded rectangle rules are cheaper (a free acrylic plate of 1.18 x 0.92 m at
#: 22.05 kHz, work 6.7e7), above it the boundary rule (the default board at 384 kHz, work
#: above 5e9; ``synth bench scale`` and ``synth bench hires`` print both).
BOUNDARY_RULE_WORK = 1e9

#: Size of a plate in wavelengths of the rectangle rule, ``kappa a b / (a + b)``
#: (``kappa = k_b + max|s| / c``, rad/m; ``a b / (a + b)`` half the area over the
#: perimeter), below which edge effect modes keep the banded rectangle rule whatever its
#: work. The rectangle rule's evaluations grow as ``n_modes (kappa a) (kappa b)``, the
#: boundary rule's as ``n_modes kappa (a + b)`` with a larger constant: their ratio grows
#: with this size. Measured (CPU seconds, both rules converged, the gains within 0.005 tol
#: of each other): the random free acrylic plate 1.38 x 1.62 m at 48 kHz of
#: ``synth bench scale`` (size 597, work 5.8e9) 40 rectangle against 53 boundary; the
#: default board at 384 kHz (size 1327, work 5.5e9) 85 against 22; the crossover, log-linear
#: between the two, near 700. ``0``: the work alone decides.
BOUNDARY_RULE_SIZE = 700.0


def _use_boundary(size, q_s, kb, c, tol, max_points) -> bool:
    """Whether edge effect modes take the boundary rule: their rectangle rule's work exceeds
    :data:`BOUNDARY_RULE_WORK` and the plate :data:`BOUNDARY_RULE_SIZE` wavelengths, or its
    check rule (``REFINE^2`` times the first one's points) would exceed ``max_points``."""
    if q_s.size == 0:
        return False
    work = _rectangle_work(size, q_s, kb, c, tol)
    if work / q_s.size * REFINE**2 > max_points:
        return True
    if work <= BOUNDARY_RULE_WORK:
        return False
    a, b = size
    kappa = kb + float(np.max(np.abs(q_s))) / c
    return kappa * a * b / (a + b) > BOUNDARY_RULE_SIZE


def _rectangle_work(size, q_s, kb, c, tol) -> float:
    """Modes times points of the rectangle rule's first rule (:func:`rectangle_points`)."""
    kappa = kb + float(np.max(np.abs(q_s))) / c
    return float(q_s.size) * rectangle_points(size, kappa, tol)


def rectangle_points(size, kappa: float, tol: float = 1e-6) -> float:
    """Points of the rectangle rule's first rule on a plate of ``size`` (a, b), metres,
    for the wavenumber ``kappa`` (bending plus acoustic, rad/m) and tolerance ``tol``,
    estimated from its longest panels (24 points each, ``2 w24 / kappa`` long); known
    before any mode is solved (:func:`synth.cost.estimate` sizes the sums' chunks by it)."""
    per_metre = MAX_ORDER * kappa / (2.0 * half_phase(MAX_ORDER, 0.1 * tol))
    return (size[0] * per_metre + 1.0) * (size[1] * per_metre + 1.0)


def _use_summed(modes, size, q_s, kb, c, tol):
    """The modes' :class:`~synth.physics.modes.SummedShapes` if :func:`plate_gains`
    should use :func:`summed_gains`, else None."""
    if q_s.size == 0 or _rectangle_work(size, q_s, kb, c, tol) <= SUMMED_RULE_WORK:
        return None
    return modes.summed()


#: Largest ratio of the wavenumbers ``kappa`` (bending plus acoustic, see
#: :mod:`~synth.sound.radiation.rectangle`) of the fastest and the slowest edge effect mode of
#: one band of :func:`_banded_rectangle`. The rectangle rule's points grow as ``kappa^2``: one
#: rule for every mode evaluates the slowest ones on the fastest one's grid; bands 1.1 apart
#: put each mode on a grid at most 1.21 times the points its own wavenumber needs, while each
#: band adds its own panels, factor tables and threads (ratios of 1.25, 1.1 and 1.06 took
#: about 100, 91 and 88 % of the evaluations of 1.25 for the random scenes of
#: ``synth bench scale`` with such modes; 1.03 and closer no less time). ``math.inf``: one
#: band.
BAND_RATIO = 1.1


def wavenumber_bands(kappa: np.ndarray, ratio: float) -> list:
    """Consecutive bands ``(start, stop)`` of modes (indices of ``kappa``, the modes in
    frequency order): a band starts at the first mode past the previous one and holds the
    following modes while their ``kappa`` stays within ``ratio`` times its first one's."""
    bands, start = [], 0
    while start < kappa.size:
        limit = kappa[start] * ratio
        stop = start + 1 + int(np.argmax(np.append(kappa[start + 1 :] > limit, True)))
        bands.append((start, stop))
        start = stop
    return bands


def _combined(parts, rule: str, message: str) -> RadiationResult:
    """One :class:`RadiationResult` of consecutive blocks of modes ``parts`` (``n_points``,
    ``panels`` those of the block with the most points)."""
    status = max(p.status for p in parts)
    largest = max(parts, key=lambda p: p.n_points)
    return RadiationResult(
        gains=np.concatenate([p.gains for p in parts]),
        error=np.concatenate([p.error for p in parts]),
        coherent=np.concatenate([p.coherent for p in parts]),
        n_points=largest.n_points,
        refinements=max(p.refinements for p in parts),
        panels=largest.panels,
        success=status == 0,
        status=status,
        message=message,
        rule=rule,
    )


def _band_rectangle(modes, start, stop, size, listener, q_s, kb, max_points, settings):
    """The rectangle rule of modes ``start <= k < stop`` alone, for the largest bending
    wavenumber among them (``kb`` scaled by the square root of their highest frequency's
    ratio to the highest mode's, as for a plate's bending waves). Edge effect modes (all
    of them at or past ``modes.edge_effect().first_mode``) take it with their factor
    tables (:func:`~synth.sound.radiation.rectangle.product_gains`)."""
    omega = modes.angular_frequencies
    index = np.arange(start, stop)
    wavenumber = kb * math.sqrt(omega[stop - 1] / omega[-1])
    edge = modes.edge_effect()
    if edge is not None and start >= edge.first_mode:

        def factors(x, y):
            return ProductFactors(*edge.product_factors(x, y, size[0], size[1], index))

        return product_gains(
            factors,
            size,
            listener,
            q_s[start:stop],
            max_wavenumber=wavenumber,
            max_points=max_points,
            **settings,
        )
    return rayleigh_gains(
        lambda points: modes.shapes(points, index=index),
        size,
        listener,
        q_s[start:stop],
        max_wavenumber=wavenumber,
        max_points=max_points,
        full_output=True,
        **settings,
    )


def _banded_rectangle(modes, n_low, size, listener, q_s, kb, c, max_points, settings):
    """The rectangle rule of the edge effect modes ``n_low`` onwards, band by band of
    wavenumber (:data:`BAND_RATIO`): each band's rule follows its own fastest mode's
    wavelength. Each mode passes the same convergence test as on one rule for every mode."""
    omega = modes.angular_frequencies[n_low:]
    kappa = kb * np.sqrt(omega / omega[-1]) + np.abs(q_s[n_low:]) / c
    parts = [
        _band_rectangle(
            modes, n_low + lo, n_low + hi, size, listener, q_s, kb, max_points, settings
        )
        for lo, hi in wavenumber_bands(np.maximum.accumulate(kappa), BAND_RATIO)
    ]
    largest = max(parts, key=lambda p: p.n_points)
    failed = sum(not p.success for p in parts)
    message = (
        f"{len(parts)} bands of wavenumber, {failed} not converged; the largest rule "
        f"{largest.message}"
    )
    return _combined(parts, "rectangle", message)


def _hybrid_gains(modes, edge, size, listener, q_s, kb, rho, c, r0, tol, max_points, boundary):
    """Gains of a plate with Rayleigh-Ritz modes below ``edge.first_mode`` (the rectangle
    rule, for their own largest wavenumber) and dynamic edge effect modes above: the
    boundary rule of :func:`~synth.sound.radiation.boundary.boundary_rule` if ``boundary``
    (``rule`` "boundary"), else rectangle rules band by band of wavenumber
    (:func:`_banded_rectangle`, ``rule`` "rectangle"); one :class:`RadiationResult`."""
    n_low = edge.first_mode
    settings = dict(air_density=rho, sound_speed=c, reference_distance=r0, tol=tol)
    if boundary:
        high = boundary_rule(
            edge, len(modes), size, listener, q_s[n_low:], max_points=max_points, **settings
        )
        how, rule = "boundary rule", "boundary"
    else:
        high = _banded_rectangle(modes, n_low, size, listener, q_s, kb, c, max_points, settings)
        how, rule = "rectangle rule", "rectangle"
    if n_low == 0:
        return dataclasses.replace(high, rule=rule)
    low = _band_rectangle(modes, 0, n_low, size, listener, q_s, kb, max_points, settings)
    message = (
        f"Ritz modes 0-{n_low - 1}: {low.message}; edge effect modes {n_low}-"
        f"{len(modes) - 1} ({how}): {high.message}"
    )
    return _combined((low, high), rule, message)


def plate_gains(
    modes,
    listener_position,
    s,
    *,
    max_wavenumber,
    air_density=AIR_DENSITY,
    sound_speed=SOUND_SPEED,
    reference_distance=None,
    tol=1e-6,
    max_points=DEFAULT_MAX_POINTS,
    full_output=False,
    cache=True,
):
    """:func:`rayleigh_gains` of a plate's modes, cached in memory and on disk.

    Parameters
    ----------
    modes : synth.physics.modes.Modes
        The plate's modes; their :meth:`~synth.physics.modes.Modes.shapes` are the
        normal-velocity shapes and the plate's length and width the size.
    listener_position, s, max_wavenumber, air_density, sound_speed, reference_distance, tol,
    max_points, full_output
        As for :func:`rayleigh_gains` (``s`` one complex frequency per mode, rad/s).
    cache : bool
        Reuse and store the result (memory and disk). ``False`` computes afresh
        and stores nothing.

    Returns
    -------
    gains : ndarray of complex, shape (n_modes,)
        ``H_k(s_k)``, Pa per (m/s) of modal velocity (read-only); or a
        :class:`RadiationResult` if ``full_output``.

    Raises
    ------
    ParameterError
        If ``modes`` is not a :class:`~synth.physics.modes.Modes`, ``s`` does not have one
        entry per mode, ``cache`` is not a bool, or as :func:`rayleigh_gains`.

    Notes
    -----
    The result is stored under a key made of everything that determines it:
    :attr:`~synth.physics.modes.Modes.shape_key` (the plate's size and eigen-solution),
    the listener position, the poles ``s`` (exact bytes), the maximum wavenumber,
    the air constants, the reference distance, ``tol``, ``max_points`` and the
    quadrature's settings. Files ``radiation-gains-*.npz`` sit beside the mode
    cache (:func:`synth.physics.modes.cache_dir`, ``$SYNTH_CACHE_DIR``) and are written
    atomically; an unreadable or inconsistent file is ignored and rewritten. A
    result loaded from disk equals the computed one exactly (the
    convergence warning, if any, is repeated).
    """
    if not isinstance(modes, Modes):
        raise ParameterError(f"modes={modes!r} must be a synth.physics.modes.Modes")
    if not isinstance(cache, bool):
        raise ParameterError(f"cache={cache!r} must be True or False")
    listener = check_listener(listener_position)
    q_s = check_poles(s)
    if q_s.size != len(modes):
        raise ParameterError(
            f"s has {q_s.size} poles for {len(modes)} modes: one complex frequency (rad/s) "
            f"per mode is needed"
        )
    kb, rho, c, r0, tol = check_settings(
        max_wavenumber, air_density, sound_speed, reference_distance, tol, max_points
    )

    size = (modes.plate.length, modes.plate.width)
    edge = modes.edge_effect()
    boundary = edge is not None and _use_boundary(size, q_s, kb, c, tol, max_points)
    separable = None if edge is not None else _use_separable(modes, size, listener, q_s, kb, c, tol)
    summed = None
    if edge is None and separable is None:
        summed = _use_summed(modes, size, q_s, kb, c, tol)

    def compute():
        if edge is not None:
            result = _hybrid_gains(
                modes, edge, size, listener, q_s, kb, rho, c, r0, tol, max_points, boundary
            )
            return frozen(result)
        settings = dict(
            max_wavenumber=kb,
            air_density=rho,
            sound_speed=c,
            reference_distance=r0,
            tol=tol,
            max_points=max_points,
            full_output=True,
        )
        if summed is not None:
            result = summed_gains(summed, listener, q_s, **settings)
        elif separable is not None:
            result = separable_gains(separable, listener, q_s, **settings)
        else:
            result = rayleigh_gains(modes.shapes, size, listener, q_s, **settings)
        return frozen(result)

    if not cache:
        result = compute()
        CACHE.count("computed")
    else:
        key = gains_key(
            modes,
            listener,
            q_s,
            kb,
            rho,
            c,
            r0,
            tol,
            max_points,
            separable is not None or summed is not None,
            rule=None if edge is None else "boundary" if boundary else "banded",
        )
        result = CACHE.get(key)
        if result is None:
            result = load_gains(key, q_s.size)
            if result is not None:
                CACHE.put(key, result, source="disk")
            else:
                result = compute()
                CACHE.put(key, result, source="computed")
                save_gains(result, key)
    if full_output:
        return result
    if not result.success:
        warn_unconverged("plate_gains", result, tol)
    return result.gains


def distance(listener_position, reference_point) -> float:
    """Distance from the microphone to a point of the plate, metres.

    Parameters
    ----------
    listener_position : (float, float, float)
        ``(x, y, z)`` of the microphone, metres, ``z > 0``.
    reference_point : (float, float)
        ``(x, y)`` of a point in the plate's plane (``z = 0``), metres.

    Returns
    -------
    float
        ``|xL - xr|``, metres (the ``reference_distance`` of :func:`rayleigh_gains`).
    """
    xl, yl, zl = check_listener(listener_position)
    xr, yr = checks.point("reference_point", reference_point, 2)
    return math.sqrt((xl - xr) ** 2 + (yl - yr) ** 2 + zl * zl)


def delay(listener_position, reference_point, sound_speed=SOUND_SPEED) -> float:
    """Propagation delay from a point of the plate to the microphone, seconds.

    Parameters
    ----------
    listener_position : (float, float, float)
        ``(x, y, z)`` of the microphone, metres, ``z > 0``.
    reference_point : (float, float)
        ``(x, y)`` of a point in the plate's plane (``z = 0``), metres.
    sound_speed : float > 0
        Speed of sound in air, m/s.

    Returns
    -------
    float
        ``|xL - xr| / c``, seconds: the delay to apply to gains computed with
        ``reference_distance = distance(listener_position, reference_point)``.
    """
    c = checks.positive("sound_speed", sound_speed, "m/s")
    return distance(listener_position, reference_point) / c
