"""The plate's modes driven by a rolling contact's force at a moving point (docs/rolling.md, "The
force as a signal", "Rendering a path"): the force is held over each sample, so each mode's step
is exact; ``b_k = phi_k(x(t)) / M_k`` is tabulated along the path (:func:`path_excitation`)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from synth import checks
from synth.compilation import compiled
from synth.errors import ParameterError
from synth.sound.modal_bank import Bank, kept_modes, ring_bank, synthesize
from synth.sound.modal_bank.pulse import response_per_transform

#: Points of the mode-shape table per bending wavelength of the highest mode.
POINTS_PER_WAVELENGTH = 32


@dataclass(frozen=True, eq=False)
class PathExcitation:
    """``excitation`` (P, K) ``b_k = phi_k / M_k`` (1/kg) along a straight path at its coordinates
    ``start + i step`` (m), and ``direct`` (P, K) an accelerometer's ``phi_k(xp) b_k`` (m/s^2 per
    N) there (None for a microphone)."""

    start: float
    step: float
    excitation: np.ndarray
    direct: np.ndarray | None

    def modes(self, keep) -> PathExcitation:
        """This table for the modes of the mask ``keep`` (K,) only."""
        direct = None if self.direct is None else np.ascontiguousarray(self.direct[:, keep])
        return PathExcitation(
            self.start, self.step, np.ascontiguousarray(self.excitation[:, keep]), direct
        )


def table_step(model) -> float:
    """The default row spacing (m) of a modal model's :func:`path_excitation`:
    :data:`POINTS_PER_WAVELENGTH` rows per bending wavelength of its highest rendered mode, the
    thin plate's ``k_b = (omega^2 rho h / D)^(1/4)`` (rad/m); 1 m without modes."""
    w = float(np.max(np.abs(model.poles.imag))) if model.poles.size else 0.0
    plate = model.modes.plate
    k_b = (w * w * plate.surface_density / plate.flexural_rigidity) ** 0.25
    return 2.0 * math.pi / (POINTS_PER_WAVELENGTH * k_b) if k_b > 0.0 else 1.0


def path_excitation(
    model, *, origin, direction, start: float, stop: float, step: float | None = None
) -> PathExcitation:
    """:class:`PathExcitation` of a :class:`synth.sound.render.ModalModel` along ``origin + s
    direction`` (m, unit ``direction``) for ``start <= s <= stop`` (m), rows every ``step`` m
    (default :func:`table_step`)."""
    ox, oy = checks.point("origin", origin, 2)
    ux, uy = checks.point("direction", direction, 2, "dimensionless")
    if not abs(math.hypot(ux, uy) - 1.0) <= 1e-12:
        raise ParameterError(f"direction={direction!r} must be a unit vector")
    s0 = checks.real("start", start, "metres")
    s1 = checks.real("stop", stop, "metres")
    if not s1 >= s0:
        raise ParameterError(f"stop={stop!r} must be >= start={start!r} (metres)")
    ds = table_step(model) if step is None else checks.positive("step", step, "metres")
    rows = max(2, int(math.ceil((s1 - s0) / ds)) + 1)
    ds = (s1 - s0) / (rows - 1) if s1 > s0 else 1.0
    s = s0 + ds * np.arange(rows)
    s[-1] = s1  # the table ends exactly at the path's last point
    points = np.column_stack((ox + ux * s, oy + uy * s))
    masses = np.asarray(model.modes.modal_masses, dtype=float)[model.rendered]
    b = np.ascontiguousarray(model.modes.shapes(points)[:, model.rendered] / masses)
    shape = model.listener.shape
    direct = None if shape is None else np.ascontiguousarray(b * np.asarray(shape).real)
    return PathExcitation(s0, ds, b, direct)


def _contact_table(model, rolling, origin, direction) -> PathExcitation:
    """:func:`path_excitation` over the contact coordinates (m) a rolling's force covers."""
    c = rolling.contact_coordinate
    return path_excitation(model, origin=origin, direction=direction,
                           start=float(np.min(c)), stop=float(np.max(c)))  # fmt: skip


@dataclass(eq=False)
class ModeState:
    """The modes' ``zeta`` (K,) complex, m/s, and the last period's force ``previous`` (N) between
    two calls of :func:`drive_modes` (updated in place by it)."""

    zeta: np.ndarray
    previous: float = 0.0

    @classmethod
    def at_rest(cls, modes: int) -> ModeState:
        """The plate at rest and unloaded, ``modes`` modes."""
        return cls(np.zeros(int(modes), dtype=complex), 0.0)


def drive_modes(
    force,
    coordinate,
    path: PathExcitation,
    poles,
    output,
    samplerate,
    *,
    preload: float = 0.0,
    state: ModeState | None = None,
) -> np.ndarray:
    """The listener's signal (N,) at ``j / samplerate`` (Pa or m/s^2) of the modes of ``poles``
    (K,) (rad/s, below Nyquist) and gains ``output`` (K,) (as :func:`synth.sound.modal_bank.
    synthesize`) driven by ``force`` (N,), each period's mean (N), at the path coordinates
    ``coordinate`` (N,) (m, within ``path``'s table). ``preload``: the force before the first
    period (N; the modes start in their static deflection ``-b_k F / p_k``). ``state``: start
    where an earlier call left the modes (``preload`` then 0) and leave the end's state in it:
    consecutive calls give the signal of one call."""
    fs = checks.samplerate(samplerate)
    F, c = _read_only(force), _read_only(coordinate)
    if F.ndim != 1 or c.shape != F.shape:
        raise ParameterError(
            f"force {F.shape} and coordinate {c.shape} must be 1-D arrays of one length"
        )
    p = np.ascontiguousarray(poles, dtype=complex)
    out_gain = np.ascontiguousarray(output, dtype=complex)
    K = p.size
    if path.excitation.shape[1] != K or out_gain.shape != (K,):
        raise ParameterError(
            f"path has {path.excitation.shape[1]} modes, poles {K}, output "
            f"{out_gain.shape}: they must agree"
        )
    if K and not np.all(np.abs(p.imag) < math.pi * fs):
        raise ParameterError(f"poles: every |Im p| must be below Nyquist, pi * {fs} rad/s")
    last = path.start + path.step * (path.excitation.shape[0] - 1)
    if F.size and not (
        np.all(np.isfinite(F))
        and np.min(c) >= path.start - 1e-9 * path.step
        and np.max(c) <= last + 1e-9 * path.step
    ):
        raise ParameterError(
            f"force must be finite and coordinate within the path's table [{path.start!r}, "
            f"{last!r}] m"
        )
    F_pre = checks.real("preload", preload, "N")
    if state is not None:
        if F_pre != 0.0:
            raise ParameterError(f"preload={preload!r}: give a preload or a state, not both")
        if not isinstance(state, ModeState) or np.shape(state.zeta) != (K,):
            raise ParameterError(f"state={state!r} must be a ModeState of {K} modes")
    # the ringing over one sample and the listener's response per unit state, as the
    # modal bank has them (unit excitation: b_k moves with the contact point here)
    ringing = np.exp(p * (1.0 / fs))
    listener = response_per_transform(p, np.ones(K), out_gain)
    hold = (np.exp(p / fs) - 1.0) / p
    audio = np.zeros(F.size)
    zeta = np.zeros(K, dtype=complex)
    if F_pre != 0.0 and F.size:
        zeta = -_row_at(path.excitation, path.start, path.step, c[0]) * F_pre / p
    if state is not None:
        zeta, F_pre = np.array(state.zeta, dtype=complex), float(state.previous)

    def ring(modes, gain, w, direct, out):
        """:func:`_drive` of the modes of the mask ``modes`` into ``out``: the ``gain`` ``g_k``
        of a unit drive ``b_k F`` and the state ``w_k`` (heard: ``Re w_k``) of those modes;
        returns their final ``w_k``."""
        wr, wi = np.ascontiguousarray(w.real), np.ascontiguousarray(w.imag)
        e = ringing[modes]
        _drive(
            F, c, float(path.start), float(path.step),
            np.ascontiguousarray(path.excitation[:, modes]),
            np.zeros(2) if direct is None else np.ascontiguousarray(direct), direct is not None,
            np.ascontiguousarray(e.real), np.ascontiguousarray(e.imag),
            np.ascontiguousarray(gain.real), np.ascontiguousarray(gain.imag), wr, wi, F_pre, out,
        )  # fmt: skip
        return wr + 1j * wi

    # the modes the listener hears, as heard: w_k = l_k zeta_k (l_k its response)
    heard = listener != 0.0
    # the direct term's sum over the modes at each row: interpolated as the rows are
    direct = None if path.direct is None else np.sum(path.direct, axis=1)
    l_heard = listener[heard]
    zeta[heard] = ring(heard, l_heard * hold[heard], l_heard * zeta[heard], direct, audio) / l_heard
    if state is not None:
        silent = ~heard
        if silent.any():  # the modes nobody hears: their state alone, as they are (l_k = 1)
            zeta[silent] = ring(silent, hold[silent], zeta[silent], None, np.zeros(F.size))
        state.zeta = zeta
        state.previous = float(F[-1]) if F.size else F_pre
    return audio


def _read_only(samples) -> np.ndarray:
    """``samples`` as a read-only C-contiguous float64 array (a view where it is one): the
    compiled drive then takes one type of input whether the caller's array is writable or
    not (a read-only one is a view of a table or a cache), so it compiles once."""
    view = np.ascontiguousarray(samples, dtype=float).view()
    view.flags.writeable = False
    return view


def mode_bounds(force, path: PathExcitation, poles, output, samplerate, *,
                preload: float = 0.0, state: ModeState | None = None) -> np.ndarray:  # fmt: skip
    """A bound (K,) of each mode's part of :func:`drive_modes`' signal at every sample, for the same
    arguments: ``|zeta_k| <= |zeta_k(0)| + |h_k| G_k / (1 - |e_k|)`` (a geometric series; ``G_k``
    the largest ``|b_k| |F|``, ``e_k = e^(p_k / fs)``, ``h_k`` the hold's gain), heard at most
    ``|l_k|`` times, plus an accelerometer's largest ``|F| |phi_k(xp) b_k|``."""
    fs = checks.samplerate(samplerate)
    p = np.asarray(poles, dtype=complex)
    F = np.asarray(force, dtype=float)
    f_max = float(np.max(np.abs(F))) if F.size else 0.0
    listener = np.abs(response_per_transform(p, np.ones(p.size), np.asarray(output, complex)))
    b_max = np.max(np.abs(path.excitation), axis=0)
    if state is not None:
        start = np.abs(np.asarray(state.zeta))
    else:
        start = b_max * abs(checks.real("preload", preload, "N")) / np.abs(p)
    drive = b_max * f_max
    with np.errstate(divide="ignore"):
        ringing = np.abs((np.exp(p / fs) - 1.0) / p) / (1.0 - np.exp(p.real / fs))
    # an undamped mode's ringing sum has no bound unless nothing drives it
    bounds = listener * (start + np.where(drive > 0.0, ringing * drive, 0.0))
    if path.direct is not None:
        bounds = bounds + f_max * np.max(np.abs(path.direct), axis=0)
    return bounds


def audible_modes(force, path: PathExcitation, poles, output, samplerate, *, floor: float,
                  reference: float, preload: float = 0.0) -> np.ndarray:  # fmt: skip
    """The mask (K,) of the modes whose :func:`mode_bounds` may exceed their share of ``floor *
    reference`` (a fraction, an amplitude) by :func:`synth.sound.modal_bank.kept_modes`' rule."""
    f = checks.nonnegative("floor", floor, "dimensionless")
    ref = checks.nonnegative("reference", reference, "the signal's units")
    bounds = mode_bounds(force, path, poles, output, samplerate, preload=preload)
    return kept_modes(bounds, ref, f)[0]


def _row_at(table, start, step, coordinate) -> np.ndarray:
    """The table's row at ``coordinate`` (m), interpolated linearly as :func:`_drive` does."""
    u = (coordinate - start) / step
    i = min(max(int(math.floor(u)), 0), table.shape[0] - 2)
    t = u - i
    return (1.0 - t) * table[i] + t * table[i + 1]


@compiled(inline="always")
def _row(coordinate, start, step, rows):  # pragma: no cover - compiled
    """The table's interval ``i`` holding ``coordinate`` (m; the first or the last beyond its
    ends) and the fraction ``t`` through it."""
    u = (coordinate - start) / step
    i = int(math.floor(u))
    if i < 0:
        i = 0
    if i > rows - 2:
        i = rows - 2
    return i, u - i


@compiled(inline="always", sums=True, nogil=True)
def drive_sample(wa, wb, row_a, row_b, er, ei, lr, li, hr, hi, zr, zi):  # noqa: PLR0913
    """One sample of the recursion (docs/rolling.md, "The force as a signal") for the modes
    ``zr + i zi`` (in place) driven at ``wa row_a + wb row_b`` (N): what the listener
    (``lr + i li``) hears at its start."""
    acc = 0.0
    for k in range(er.shape[0]):
        acc += lr[k] * zr[k] - li[k] * zi[k]
        bf = wa * row_a[k] + wb * row_b[k]
        r = er[k] * zr[k] - ei[k] * zi[k] + hr[k] * bf
        zi[k] = er[k] * zi[k] + ei[k] * zr[k] + hi[k] * bf
        zr[k] = r
    return acc


@compiled(inline="always")
def _direct_at(direct, i, t, F, previous):  # pragma: no cover - compiled
    """An accelerometer's direct term at ``t`` of interval ``i``: the mean of ``previous`` and
    ``F`` (N) times the summed ``direct`` row."""
    return 0.5 * (F + previous) * ((1.0 - t) * direct[i] + t * direct[i + 1])


@compiled(inline="always")
def _interval_gains(row_a, row_b, gr, gi, ar, ai, br, bi):  # pragma: no cover - compiled
    """The gains ``g_k b_k`` of the interval's two rows, into ``ar + i ai`` and ``br + i bi``."""
    for k in range(gr.shape[0]):
        ar[k] = gr[k] * row_a[k]
        ai[k] = gi[k] * row_a[k]
        br[k] = gr[k] * row_b[k]
        bi[k] = gi[k] * row_b[k]


@compiled(inline="always")
def _ring_one(fa, fb, er, ei, ar, ai, br, bi, wr, wi):  # noqa: PLR0913  # pragma: no cover
    """One period of the heard modes ``wr + i wi`` (in place) driven by the parts ``fa``, ``fb``
    (N) of the force on the interval's two rows; returns the signal at its start."""
    acc = 0.0
    for k in range(er.shape[0]):
        xr, xi = wr[k], wi[k]
        acc += xr
        wr[k] = er[k] * xr - ei[k] * xi + ar[k] * fa + br[k] * fb
        wi[k] = er[k] * xi + ei[k] * xr + ai[k] * fa + bi[k] * fb
    return acc


@compiled(inline="always")
def _ring_four(fa, fb, er, ei, ar, ai, br, bi, wr, wi):  # noqa: PLR0913  # pragma: no cover
    """:func:`_ring_one` for four consecutive sample periods in one interval, each mode's
    state and gains loaded once for all four."""
    a0, a1, a2, a3 = fa[0], fa[1], fa[2], fa[3]
    b0, b1, b2, b3 = fb[0], fb[1], fb[2], fb[3]
    s0 = s1 = s2 = s3 = 0.0
    for k in range(er.shape[0]):
        e_r, e_i, g_ar, g_ai, g_br, g_bi = er[k], ei[k], ar[k], ai[k], br[k], bi[k]
        xr, xi = wr[k], wi[k]
        s0 += xr
        r = e_r * xr - e_i * xi + g_ar * a0 + g_br * b0
        xi = e_r * xi + e_i * xr + g_ai * a0 + g_bi * b0
        xr = r
        s1 += xr
        r = e_r * xr - e_i * xi + g_ar * a1 + g_br * b1
        xi = e_r * xi + e_i * xr + g_ai * a1 + g_bi * b1
        xr = r
        s2 += xr
        r = e_r * xr - e_i * xi + g_ar * a2 + g_br * b2
        xi = e_r * xi + e_i * xr + g_ai * a2 + g_bi * b2
        xr = r
        s3 += xr
        wr[k] = e_r * xr - e_i * xi + g_ar * a3 + g_br * b3
        wi[k] = e_r * xi + e_i * xr + g_ai * a3 + g_bi * b3
    return s0, s1, s2, s3


@compiled(inline="always")
def _ring_four_free(er, ei, wr, wi):  # pragma: no cover - compiled
    """:func:`_ring_four` without force (the ball in flight; the same bits)."""
    s0 = s1 = s2 = s3 = 0.0
    for k in range(er.shape[0]):
        e_r, e_i = er[k], ei[k]
        xr, xi = wr[k], wi[k]
        s0 += xr
        r = e_r * xr - e_i * xi
        xi = e_r * xi + e_i * xr
        xr = r
        s1 += xr
        r = e_r * xr - e_i * xi
        xi = e_r * xi + e_i * xr
        xr = r
        s2 += xr
        r = e_r * xr - e_i * xi
        xi = e_r * xi + e_i * xr
        xr = r
        s3 += xr
        wr[k] = e_r * xr - e_i * xi
        wi[k] = e_r * xi + e_i * xr
    return s0, s1, s2, s3


@compiled(sums=True, nogil=True)
def _drive(  # noqa: PLR0913
    force, coordinate, start, step, table, direct, has_direct, er, ei, gr, gi, wr, wi,
    previous, out,
):  # fmt: skip  # pragma: no cover - compiled
    """The recursion (docs/rolling.md, "The force as a signal") for the heard modes
    ``w_k = l_k zeta_k`` (``wr + i wi``, in place; ``sum_k Re w_k`` into ``out``):
    ``w_k <- e_k w_k + g_k b_k F``, ``b_k`` interpolated in ``table``; ``previous`` the force
    before (N), ``direct`` the direct term summed per row. Four samples rung per pass, each with
    a single pass' bits."""
    K = er.shape[0]
    rows = table.shape[0]
    n = force.shape[0]
    ar, ai, br, bi = np.empty(K), np.empty(K), np.empty(K), np.empty(K)
    fa, fb, ts = np.empty(4), np.empty(4), np.empty(4)
    interval = -1
    j = 0
    while j < n:
        i, t = _row(coordinate[j], start, step, rows)
        if i != interval:
            _interval_gains(table[i], table[i + 1], gr, gi, ar, ai, br, bi)
            interval = i
        # the samples from j on in this interval, at most four
        m = 0
        while m < 4 and j + m < n:
            i_m, t_m = _row(coordinate[j + m], start, step, rows)
            if i_m != i:
                break
            fa[m] = (1.0 - t_m) * force[j + m]
            fb[m] = t_m * force[j + m]
            ts[m] = t_m
            m += 1
        if m == 4 and force[j] == force[j + 1] == force[j + 2] == force[j + 3] == 0.0:
            out[j], out[j + 1], out[j + 2], out[j + 3] = _ring_four_free(er, ei, wr, wi)
        elif m == 4:
            out[j], out[j + 1], out[j + 2], out[j + 3] = _ring_four(
                fa, fb, er, ei, ar, ai, br, bi, wr, wi
            )
        else:
            m = 1
            out[j] = _ring_one(fa[0], fb[0], er, ei, ar, ai, br, bi, wr, wi)
        for q in range(m):
            F = force[j + q]
            if has_direct:
                # the held force jumps at t_j: its value there is the mean of both sides
                out[j + q] += _direct_at(direct, i, ts[q], F, previous)
            previous = F
        j += m


def rolling_sound(rolling, model, *, floor: float = 0.0, reference: float = 0.0) -> np.ndarray:
    """What ``model``'s listener (a :class:`synth.sound.render.ModalModel` at the rolling's
    samplerate) hears of a :class:`synth.physics.rolling.RollingContact` (without the delay
    ``model.delay``), the plate loaded with the first period's force. Modes within their share
    of ``floor * reference`` (:func:`audible_modes`; Pa or m/s^2) are left out (by default none)."""
    if int(model.samplerate) != int(rolling.samplerate):
        raise ParameterError(
            f"model.samplerate={model.samplerate!r} must equal the rolling's samplerate "
            f"{rolling.samplerate!r} (Hz)"
        )
    c = rolling.contact_coordinate
    path = _contact_table(model, rolling, rolling.origin, rolling.direction)
    f = checks.nonnegative("floor", floor, "dimensionless")
    ref = checks.nonnegative("reference", reference, "the signal's units")
    preload = float(rolling.force[0])
    poles, output = model.poles, model.output
    if f * ref > 0.0:
        keep = audible_modes(
            rolling.force, path, poles, output, rolling.samplerate,
            floor=f, reference=ref, preload=preload,
        )  # fmt: skip
        path, poles, output = path.modes(keep), poles[keep], output[keep]
    return drive_modes(rolling.force, c, path, poles, output, rolling.samplerate, preload=preload)


def render_path_audio(scene, model, o) -> tuple[np.ndarray, object, dict]:
    """The signal (Pa or m/s^2) of ``scene`` (with a velocity) heard through ``model`` (a
    :class:`synth.sound.listener.ModalModel`) with the render options ``o``, its
    :class:`~synth.physics.path.BallPath`, and its :class:`~synth.sound.result.RenderInfo`'s
    figures (``path`` a :class:`~synth.sound.result.PathInfo`)."""
    from synth.physics.path import simulate_path
    from synth.sound.result import PathInfo

    fs = o.samplerate
    floor = 10.0 ** (o.floor_db / 20.0)
    pre, delay = o.preroll, model.delay
    first_touch = math.sqrt(2.0 * scene.drop_height / scene.gravity)
    origin_time = first_touch - pre  # the emission time of the audio's first sample
    path = simulate_path(scene, samplerate=fs, time_origin=origin_time, max_duration=o.max_duration)
    bounces, bank = _bounces(path, model, fs, floor, origin_time, o)
    rolling = path.rolling
    info = dict(
        n_modes_rendered=bank["n_modes_rendered"],
        mode_samples=bank["mode_samples"],
        bank_seconds=bank["bank_seconds"],
        reference_amplitude=bank["reference"],
        tail_cut=False,
        left_at_end=bank["left_at_end"] / bank["reference"] if bank["reference"] else 0.0,
    )
    if rolling is None:
        audio = bounces
    else:
        audio, tail, driven = _with_rolling(
            bounces, rolling, path, model, fs, floor, origin_time, o
        )
        info.update(tail, n_modes_rendered=max(info["n_modes_rendered"], driven))
    path_info = PathInfo(
        path_end=path.end,
        path_end_time=path.end_time,
        path_end_point=tuple(path.end_point),
        rolling_speed=path.rolling_speed,
        rolling_start=None if rolling is None else rolling.start,
        rolling_seconds=0.0 if rolling is None else rolling.duration,
        rolling_flights=0 if rolling is None else rolling.flights,
        contact_plate="impedance",
        rolling_mode_samples=info.pop("rolling_mode_samples", None),
    )
    figures = dict(delay=delay, audio_start=first_touch + delay - pre, path=path_info, **info)
    return audio, path, figures


def _bounces(path, model, fs, floor, origin_time, o) -> tuple[np.ndarray, dict]:
    """The bounces' part of the signal from the audio's first sample, and the bank's figures."""
    impacts = path.impacts
    excitation = model.excitations(path.impact_points)
    direct = None if model.listener.shape is None else model.listener.shape * excitation
    onsets = np.array([i.time for i in impacts]) - origin_time
    max_samples = int(math.ceil((impacts.duration - origin_time + o.max_tail) * fs))
    return synthesize(
        [i.result for i in impacts], onsets, Bank(model.poles, excitation, model.output, fs),
        floor=floor, direct=direct, max_samples=max_samples, pulse_points=o.pulse_points,
    )  # fmt: skip


def _with_rolling(bounces, rolling, path, model, fs, floor, origin_time, o):
    """The bounces' signal with the rolling's and its tail added, and the rolling's figures."""
    j0 = int(round((rolling.start - origin_time) * fs))
    c = rolling.contact_coordinate
    table = _contact_table(model, rolling, path.origin, path.direction)
    # the modes within their share of the floor under the bounces' peak are left out
    bounce_peak = float(np.max(np.abs(bounces))) if bounces.size else 0.0
    keep = audible_modes(
        rolling.force, table, model.poles, model.output, fs, floor=floor, reference=bounce_peak
    )
    kept = ModeState.at_rest(int(keep.sum()))
    drive = drive_modes(
        rolling.force, c, table.modes(keep), model.poles[keep], model.output[keep], fs,
        state=kept,
    )  # fmt: skip
    state = ModeState.at_rest(model.poles.size)
    state.zeta[keep], state.previous = kept.zeta, kept.previous
    reference = max(bounce_peak, float(np.max(np.abs(drive))))
    tail, cut, left = _tail(state, rolling, path, model, fs, floor * reference, o.max_tail)
    # the sum in one new array, each part added where it lies
    end = j0 + drive.size
    audio = np.empty(max(bounces.size, end + tail.size))
    audio[: bounces.size] = bounces
    audio[bounces.size :] = 0.0
    audio[j0:end] += drive
    audio[end : end + tail.size] += tail
    work = int(keep.sum()) * drive.size
    figures = dict(tail_cut=cut, left_at_end=left / reference, rolling_mode_samples=work)
    return audio, figures, int(keep.sum())


def _tail(state, rolling, path, model, fs, floor, max_tail) -> tuple[np.ndarray, bool, float]:
    """The signal after the rolling, whether ``max_tail`` (s) cut it, and the bound of what rings
    on. Under the last force held at its last point each mode rings towards its static
    deflection ``zs_k = -b_k F / p_k``: the modal bank's ringing of ``zeta_k - zs_k`` (each
    until within its share of ``floor``) plus the deflection's constant signal."""
    p = model.poles
    end = float(rolling.contact_coordinate[-1])
    point = (path.origin[0] + path.direction[0] * end, path.origin[1] + path.direction[1] * end)
    b = model.excitation(point)
    F = rolling.final_force
    static = -b * F / p
    gain = response_per_transform(p, np.ones(p.size), model.output)
    constant = float(np.sum((gain * static).real))
    direct = model.direct(b)
    if direct is not None:
        constant += F * float(np.sum(direct.real))
    out = np.zeros(int(math.ceil(max_tail * fs)))
    amplitudes = (gain * (state.zeta - static))[None, :]
    thresholds = np.full(p.size, floor / max(p.size, 1))
    _, last, left = ring_bank(out, float(fs), p, amplitudes, np.zeros(1, np.int64), thresholds)
    last = max(int(last), 1)
    return out[:last] + constant, bool(last >= out.size and left > floor), float(left)
