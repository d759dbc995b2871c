"""The rectangle rule on grids fixed for every listener above a height (:class:`ListenerGrid`):
shapes evaluated once, so the gains at a new microphone are one pass of the sums, for the live
engine's moving listener (:meth:`synth.live.Body.move`); one grid per band of modes."""

from __future__ import annotations

import math
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import numba
import numpy as np

from synth.constants import AIR_DENSITY, SOUND_SPEED
from synth.errors import ParameterError, SynthError
from synth.sound.radiation.common import (
    Poles,
    add_sums,
    check_listener,
    distance_range,
    exp_halvings,
    panel_length,
    pole_factor,
)
from synth.sound.radiation.rectangle import panel_nodes, panel_orders

#: Lowest microphone (m above the plate's plane) the fixed grids serve: their panels are at
#: most this long. A game's listener (a head) is rarely closer to a surface.
NEAR_FIELD_HEIGHT = 0.1
#: Microphones whose gains a grid keeps (the latest): the bodies of one plate moved to one
#: listener compute its gains once.
KEPT_MICROPHONES = 8
#: Most memory (bytes) the fixed grids of one plate take by default (8 bytes per mode and
#: point); a plate whose grids would take more keeps the exact rule for every listener.
MAX_GRID_BYTES = 256 * 2**20


class GridTooLarge(SynthError):
    """The fixed grids of a plate would take more than their memory budget."""


@dataclass(frozen=True, eq=False)
class _Band:
    """Modes ``start <= k < stop`` on one tensor grid: the points ``x`` and ``y`` (m, (N,)),
    the weights ``w`` (m^2, (N,)) and the shapes ``phi`` ((N, stop - start), C order)."""

    start: int
    stop: int
    x: np.ndarray
    y: np.ndarray
    w: np.ndarray
    phi: np.ndarray


class ListenerGrid:
    """The Rayleigh gains of a plate's ``modes`` at any microphone at least ``height`` m
    above the plate (:meth:`gains`), from shapes evaluated once on fixed grids: ``s`` the
    modes' complex frequencies (rad/s), ``max_wavenumber`` their largest bending wavenumber
    (rad/m), ``tol`` the rectangle rule's; :class:`GridTooLarge` beyond ``max_bytes``
    (default :data:`MAX_GRID_BYTES`), before any shape is evaluated."""

    def __init__(
        self,
        modes,
        s,
        *,
        max_wavenumber: float,
        air_density: float = AIR_DENSITY,
        sound_speed: float = SOUND_SPEED,
        height: float = NEAR_FIELD_HEIGHT,
        tol: float = 1e-6,
        max_bytes: int | None = None,
    ):
        self.height = float(height)
        self.size = (modes.plate.length, modes.plate.width)
        self._rho = float(air_density)
        self._c = float(sound_speed)
        self._s = np.asarray(s, dtype=complex)
        self._q = self._s / self._c
        axes = _band_axes(modes, self._q, float(max_wavenumber), self.size, self.height, tol)
        need = sum(
            8 * (stop - start + 3) * xs.size * ys.size for start, stop, (xs, _), (ys, _) in axes
        )
        max_bytes = MAX_GRID_BYTES if max_bytes is None else max_bytes
        if need > max_bytes:
            raise GridTooLarge(
                f"the fixed radiation grids of {len(modes)} modes would take {need / 2**20:.0f} "
                f"MiB, more than max_bytes={max_bytes / 2**20:.0f} MiB"
            )
        self._bands = _bands(axes, modes)
        self._shares = _shares(self._bands, max(1, numba.get_num_threads()))
        self._kept: dict = {}  # the gains at the last few microphones, by position

    @property
    def nbytes(self) -> int:
        """Bytes of the grids and the shapes kept."""
        return sum(b.phi.nbytes + 3 * b.w.nbytes for b in self._bands)

    @property
    def points(self) -> int:
        """Exponentials a new microphone costs: modes times points of their band's grid."""
        return sum(b.w.size * (b.stop - b.start) for b in self._bands)

    def serves(self, listener_position) -> bool:
        """Whether a microphone at ``listener_position`` ((x, y, z), m) is high enough."""
        return float(listener_position[2]) >= self.height

    def gains(self, listener_position, reference_distance: float | None = None) -> np.ndarray:
        """``H_k(s_k)`` (times ``exp(s_k R0 / c)``, ``R0 = reference_distance`` m), Pa per
        (m/s) of modal velocity, of every mode at the microphone ``listener_position`` ((x,
        y, z), m, z >= :attr:`height`), as :func:`~synth.sound.radiation.plate_gains` does
        (read-only; kept for the last :data:`KEPT_MICROPHONES` microphones)."""
        xl, yl, zl = check_listener(listener_position)
        key = (xl, yl, zl, reference_distance)
        kept = self._kept.get(key)
        if kept is not None:
            return kept
        if zl < self.height:
            raise ParameterError(
                f"listener_position.z={zl!r} m is below the fixed grids' height "
                f"{self.height} m: use synth.sound.radiation.plate_gains"
            )
        r_min, r_max = distance_range(self.size, (xl, yl, zl))
        r_mid = 0.5 * (r_max + r_min)
        q = self._q
        poles = Poles.of(q, exp_halvings(q, 0.5 * (r_max - r_min)))
        acc = np.zeros((3, q.size))

        def add(bands):
            for band in bands:
                r = np.sqrt((band.x - xl) ** 2 + (band.y - yl) ** 2 + zl * zl)
                k0, k1 = band.start, band.stop
                band_poles = Poles(poles.qr[k0:k1], poles.qi[k0:k1], poles.halvings)
                add_sums(0, r.size, r - r_mid, band.w / r, band.phi, band_poles, acc[:, k0:k1])

        if len(self._shares) == 1:
            add(self._shares[0])
        else:
            with ThreadPoolExecutor(max_workers=len(self._shares)) as pool:
                for job in [pool.submit(add, share) for share in self._shares]:
                    job.result()
        r0 = None if reference_distance is None else float(reference_distance)
        gains = pole_factor(self._s, self._rho, self._c, r_mid, r0) * (acc[0] + 1j * acc[1])
        gains.setflags(write=False)
        if len(self._kept) >= KEPT_MICROPHONES:
            self._kept.pop(next(iter(self._kept)), None)
        self._kept[key] = gains
        return gains


def _shares(bands, workers: int) -> list:
    """The bands split in at most ``workers`` shares of about equal work (the largest band
    first to the least loaded share); each band's sums are its own modes', so the gains do
    not depend on the split or the timing."""
    shares = [[] for _ in range(min(workers, max(1, len(bands))))]
    load = [0] * len(shares)
    for band in sorted(bands, key=lambda b: -b.w.size * (b.stop - b.start)):
        i = load.index(min(load))
        shares[i].append(band)
        load[i] += band.w.size * (band.stop - band.start)
    return shares


def _band_axes(modes, q, kb, size, height, tol) -> list:
    """The modes' bands of wavenumber and their grids' axes: ``(start, stop, (xs, wx),
    (ys, wy))`` for modes ``start <= k < stop``."""
    from synth.sound.radiation.rules import mode_bands

    omega = np.asarray(modes.angular_frequencies, dtype=float)
    if omega.size == 0:
        return []
    kappa = kb * np.sqrt(omega / omega[-1]) + np.abs(q)
    out = []
    for start, stop in mode_bands(omega, kb, np.abs(q)):
        band_kappa = float(np.max(kappa[start:stop]))
        out.append((start, stop, *(_axis(side, band_kappa, height, tol) for side in size)))
    return out


def _bands(axes, modes) -> tuple[_Band, ...]:
    """The bands of :func:`_band_axes` with their tensor grids and the shapes on them."""
    bands = []
    for start, stop, (xs, wx), (ys, wy) in axes:
        x = np.repeat(xs, ys.size)
        y = np.tile(ys, xs.size)
        w = np.repeat(wx, ys.size) * np.tile(wy, xs.size)
        points = np.column_stack((x, y))
        phi = np.ascontiguousarray(modes.shapes(points, index=np.arange(start, stop)), float)
        if not np.isfinite(phi).all():
            raise ParameterError(f"the shapes of modes {start}-{stop - 1} are not finite")
        bands.append(_Band(start, stop, x, y, w, phi))
    return tuple(bands)


def _axis(length: float, kappa: float, height: float, tol: float):
    """Nodes and weights along one side (``length`` m) of a band's grid: equal panels at
    most ``min(2 w24 / kappa, height)`` long with the rectangle rule's first-rule orders."""
    tol_panel = 0.1 * tol
    n = max(1, math.ceil(length / min(panel_length(kappa, tol_panel), height)))
    ends = np.linspace(0.0, length, n + 1)
    return panel_nodes(ends, panel_orders(ends, kappa, tol_panel))
