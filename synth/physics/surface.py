"""A plate's surface along a ball's path (docs/rolling.md, "The surface"): the Matern roughness
profile and the envelope a sphere of radius ``R`` (m) rides."""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.interpolate import CubicSpline

from synth import checks
from synth.compilation import compiled
from synth.errors import ParameterError

#: Most samples of a profile (a 10 m path at 1 um spacing).
MAX_PROFILE_SAMPLES = 10_000_000
#: Correlation lengths of padding around the periodic synthesis domain (Matern correlation
#: below 1e-6 at that lag for every ``H <= 1``).
PADDING_CORRELATION_LENGTHS = 16.0
#: Newton iterations for a summit's contact point (quadratic from within a sample).
NEWTON_ITERATIONS = 6
#: Samples per run whose highest point bounds the runs :func:`_best_samples` may skip.
DILATION_BLOCK = 8
#: Largest RMS height and correlation length, m (the largest plate; ``sigma^2`` far from overflow).
MAX_ROUGHNESS_SCALE = 100.0


def read_only(a: np.ndarray) -> np.ndarray:
    """``a``, made read-only (the arrays a result holds)."""
    a.setflags(write=False)
    return a


def samples(name: str, value, least: int, most: int, unit: str, nonnegative=False) -> np.ndarray:
    """``value`` as a new 1-D float array of finite samples, else ``ParameterError``."""
    try:
        a = np.array(value, dtype=float)
    except (TypeError, ValueError):
        raise ParameterError(f"{name}={value!r} must be a 1-D array ({unit})") from None
    if a.ndim != 1 or not least <= a.size <= most:
        raise ParameterError(
            f"{name} with shape {a.shape} must be 1-D with {least} to {most} samples ({unit})"
        )
    bad = ~(np.isfinite(a) & (a >= 0.0)) if nonnegative else ~np.isfinite(a)
    if np.any(bad):
        i = int(np.argmax(bad))
        allowed = "finite and >= 0" if nonnegative else "finite"
        raise ParameterError(f"{name}[{i}]={a[i]!r} must be {allowed} ({unit})")
    return a


@dataclass(frozen=True, eq=False)
class Profile:
    """Heights (m, read-only) every ``spacing`` m along a straight path, with a ``description``."""

    heights: np.ndarray
    spacing: float
    description: str

    def __post_init__(self):
        h = samples("heights", self.heights, 4, MAX_PROFILE_SAMPLES, "metres")
        object.__setattr__(self, "heights", read_only(h))
        object.__setattr__(self, "spacing", checks.positive("spacing", self.spacing, "metres"))

    @property
    def length(self) -> float:
        """Length of the path the profile covers, metres."""
        return (self.heights.size - 1) * self.spacing


@dataclass(frozen=True)
class RoughnessSpectrum:
    """The Matern (von Karman) roughness spectrum (docs/rolling.md, "The surface"): two-sided
    PSD over the wavenumber ``k`` (rad/m) with ``rms_height`` ``sigma`` (m),
    ``correlation_length`` ``xi`` in (0, 100] m (:data:`MAX_ROUGHNESS_SCALE`) and ``hurst``
    ``H`` in (0, 1] (1: smooth, 0.5: Brownian)."""

    rms_height: float
    correlation_length: float
    hurst: float

    def __post_init__(self):
        for key in ("rms_height", "correlation_length"):
            value = checks.positive_at_most(key, getattr(self, key), MAX_ROUGHNESS_SCALE, "metres")
            object.__setattr__(self, key, value)
        hurst = checks.in_range("hurst", self.hurst, 0.0, 1.0, "dimensionless", hi_open=False)
        object.__setattr__(self, "hurst", hurst)

    def density(self, k) -> np.ndarray:
        """``S(k)``, m^2 / (rad/m) = m^3, at wavenumbers ``k`` (rad/m)."""
        H, xi = self.hurst, self.correlation_length
        norm = 2.0 * math.sqrt(math.pi) * xi * math.exp(math.lgamma(H + 0.5) - math.lgamma(H))
        kx = np.asarray(k, dtype=float) * xi
        return self.rms_height**2 * norm * (1.0 + kx * kx) ** -(H + 0.5)


#: Hurst exponent of the measured surfaces: ``H = 3 - D_f``, the fractal dimension ``D_f = 2.15 +-
#: 0.15`` of most natural and engineering surfaces (Persson, Tribol. Lett. 54, 99 (2014)).
SELF_AFFINE_HURST = 0.85


@dataclass(frozen=True)
class MeasuredRoughness:
    """A surface's published roughness (docs/rolling.md, "Measured surfaces"): ``Ra`` (ISO 4287,
    m) at the cut-off ``lambda_c`` (m); ``source``."""

    surface: str
    ra: float
    cutoff: float
    source: str

    @property
    def rms_height(self) -> float:
        """``sigma = Rq = sqrt(pi / 2) Ra``, m, as for a Gaussian profile."""
        return math.sqrt(0.5 * math.pi) * self.ra

    @property
    def correlation_length(self) -> float:
        """``xi = lambda_c / (2 pi)``, m: the knee at the filter's cut-off (none publishes it)."""
        return self.cutoff / (2.0 * math.pi)

    def spectrum(self) -> RoughnessSpectrum:
        """The :class:`RoughnessSpectrum` of ``sigma``, ``xi`` and :data:`SELF_AFFINE_HURST`."""
        return RoughnessSpectrum(self.rms_height, self.correlation_length, SELF_AFFINE_HURST)


#: The surfaces with a published roughness measurement (``roughness.toml``).
with open(Path(__file__).with_name("roughness.toml"), "rb") as _file:
    MEASURED_ROUGHNESS = {k: MeasuredRoughness(**row) for k, row in tomllib.load(_file).items()}


def _check_grid(length, spacing) -> tuple[float, float, int]:
    L = checks.positive("length", length, "metres")
    dx = checks.positive("spacing", spacing, "metres")
    # the ratio compared before it becomes an int: it can be too large for one (1e308)
    n = math.ceil(L / dx - 1e-9) + 1 if L / dx < MAX_PROFILE_SAMPLES else None
    if n is None or not 4 <= n <= MAX_PROFILE_SAMPLES:
        count = f"more than {MAX_PROFILE_SAMPLES}" if n is None else n
        raise ParameterError(
            f"length={length!r} with spacing={spacing!r} gives {count} samples; a profile "
            f"has 4 to {MAX_PROFILE_SAMPLES} samples (metres)"
        )
    return L, dx, n


def rough_profile(
    spectrum: RoughnessSpectrum, *, length: float, spacing: float, seed: int
) -> Profile:
    """A random profile with ``spectrum`` along ``length`` m every ``spacing`` m from ``seed``
    (PCG64): spectral synthesis on a padded periodic domain of period ``P``, Gaussian ``c_m =
    conj(c_-m)``, ``E |c_m|^2 = S(k_m) / P``, ``c_0 = 0``."""
    if not isinstance(spectrum, RoughnessSpectrum):
        raise ParameterError(f"spectrum={spectrum!r} must be a RoughnessSpectrum")
    L, dx, n = _check_grid(length, spacing)
    s = checks.integer_at_least("seed", seed, 0)
    m_total = _synthesis_size(L, dx, spectrum.correlation_length)
    k = 2.0 * math.pi * np.arange(m_total // 2 + 1) / (m_total * dx)
    variance = spectrum.density(k) / (m_total * dx)
    variance[0] = 0.0
    rng = np.random.default_rng(s)
    coef = rng.standard_normal(k.size) + 1j * rng.standard_normal(k.size)
    coef *= np.sqrt(0.5 * variance)
    coef[-1] = coef[-1].real * math.sqrt(2.0)  # the Nyquist term is real, of full variance
    heights = np.ascontiguousarray(np.fft.irfft(coef, n=m_total)[:n] * m_total)
    sp = spectrum
    return Profile(read_only(heights), dx, (
        f"Matern roughness: rms_height={sp.rms_height:g} m, correlation_length="
        f"{sp.correlation_length:g} m, hurst={sp.hurst:g}, seed={s}, spacing={dx:g} m"
    ))  # fmt: skip


def _synthesis_size(length: float, spacing: float, correlation_length: float) -> int:
    """Samples ``M`` (even) of the periodic synthesis domain of :func:`rough_profile`."""
    span = length + PADDING_CORRELATION_LENGTHS * correlation_length
    most = 4 * MAX_PROFILE_SAMPLES
    m = math.ceil(span / spacing) + 1 if span / spacing < most else math.inf
    if m > most:
        raise ParameterError(
            f"correlation_length={correlation_length!r} with spacing={spacing!r}: the "
            f"synthesis domain would hold more than {most} samples"
        )
    return m + (m % 2)


def expected_mean_square(spectrum: RoughnessSpectrum, *, length: float, spacing: float) -> float:
    """Expected mean square height (m^2) of :func:`rough_profile`: ``sum_(m != 0) S(k_m) / P``."""
    L, dx, _ = _check_grid(length, spacing)
    m_total = _synthesis_size(L, dx, spectrum.correlation_length)
    k = 2.0 * math.pi * np.arange(1, m_total // 2 + 1) / (m_total * dx)
    d = spectrum.density(k)
    # both signs of every wavenumber but the Nyquist one
    return float((2.0 * np.sum(d[:-1]) + d[-1]) / (m_total * dx))


def sinusoidal_profile(
    *, amplitude: float, wavelength: float, length: float, spacing: float, phase: float = 0.0
) -> Profile:
    """``amplitude sin(2 pi x / wavelength + phase)`` (m, rad) over ``length``, ``spacing`` (m)."""
    A = checks.positive("amplitude", amplitude, "metres")
    lam = checks.positive("wavelength", wavelength, "metres")
    phi = checks.real("phase", phase, "rad")
    L, dx, n = _check_grid(length, spacing)
    if lam < 4.0 * dx:
        raise ParameterError(
            f"wavelength={wavelength!r} must be >= 4 * spacing = {4.0 * dx!r} (metres) to be "
            f"sampled"
        )
    heights = read_only(A * np.sin(2.0 * math.pi / lam * (np.arange(n) * dx) + phi))
    text = f"amplitude={A:g} m, wavelength={lam:g} m, phase={phi:g} rad, spacing={dx:g} m"
    return Profile(heights, dx, f"sinusoid: {text}")


@dataclass(frozen=True, eq=False)
class ContactEnvelope:
    """What a sphere of ``radius`` (m) touches with its centre above ``i spacing`` (m): its lowest
    point's ``heights`` (m), the touching point's ``contact_offsets`` (m) and the not-a-knot cubic
    spline's ``coefficients`` (N - 1, 4) (C2: the centripetal acceleration is resolved)."""

    heights: np.ndarray
    contact_offsets: np.ndarray
    spacing: float
    radius: float
    description: str
    coefficients: np.ndarray

    @property
    def length(self) -> float:
        """Length of the path, metres."""
        return (self.heights.size - 1) * self.spacing


def contact_envelope(profile: Profile, radius: float) -> ContactEnvelope:
    """The envelope a sphere of ``radius`` (m) rides on ``profile``: the best sample in reach,
    refined by Newton on the profile's spline (no grid in a summit's curvature)."""
    if not isinstance(profile, Profile):
        raise ParameterError(f"profile={profile!r} must be a Profile")
    R = checks.positive("radius", radius, "metres")
    h = profile.heights
    span = float(np.max(h) - np.min(h))
    dx = profile.spacing
    # the cap's depth R - sqrt(R^2 - d^2) exceeds the span beyond d = sqrt(span (2R - span))
    reach = math.sqrt(span * (2.0 * R - span)) if span < R else R
    window = min(int(math.ceil(reach / dx)) + 1, h.size - 1)
    e = np.empty(h.size)
    off = np.empty(h.size)
    x = np.arange(h.size) * dx
    _dilate(np.ascontiguousarray(h), _spline(x, h), dx, R, _cap_depths(dx, R, window), e, off)
    text = f"{profile.description}; ball radius={R:g} m"
    return ContactEnvelope(read_only(e), read_only(off), dx, R, text, _spline(x, e))


def _spline(x, y) -> np.ndarray:
    """Not-a-knot cubic spline coefficients (N - 1, 4), read-only (one numba type)."""
    return read_only(np.ascontiguousarray(CubicSpline(x, y, bc_type="not-a-knot").c.T))


def _cap_depths(dx: float, R: float, window: int) -> np.ndarray:
    """Cap depth ``R - sqrt(R^2 - d^2)`` (m) at ``d = k dx``, ``|k| <= window``, ``+inf`` beyond."""
    d = np.arange(-window, window + 1) * dx
    q = R * R - d * d
    depths = np.full(d.size, np.inf)
    inside = d * d < R * R
    depths[inside] = R - np.sqrt(q[inside])
    return depths


@compiled()
def _best_samples(h, caps, best, first):  # pragma: no cover - compiled
    """``best_i = max_j (h_j - caps[j - i + window])`` and the first ``j`` reaching it; runs
    that cannot beat the best so far are skipped (the full scan's bits)."""
    n = h.shape[0]
    window = (caps.shape[0] - 1) // 2
    B = DILATION_BLOCK
    n_blocks = (n + B - 1) // B
    tops = np.empty(n_blocks)
    for b in range(n_blocks):
        top = -np.inf
        for j in range(b * B, min(n, b * B + B)):
            top = max(top, h[j])
        tops[b] = top
    for i in range(n):
        lo = max(0, i - window)
        hi = min(n - 1, i + window)
        b_lo = lo // B
        b_hi = hi // B
        b_mid = i // B
        g_best = -np.inf
        jb = i
        # the run holding i first, then outwards: the best rises fast, far runs are skipped
        for r in range(2 * max(b_mid - b_lo, b_hi - b_mid) + 1):
            b = b_mid + (r + 1) // 2 if r % 2 == 1 else b_mid - r // 2
            if b < b_lo or b > b_hi:
                continue
            j0 = max(lo, b * B)
            j1 = min(hi, b * B + B - 1)
            if j1 < i:
                nearest = i - j1
            elif j0 > i:
                nearest = j0 - i
            else:
                nearest = 0
            if tops[b] - caps[nearest + window] < g_best:
                continue
            for j in range(j0, j1 + 1):
                g = h[j] - caps[j - i + window]
                if g > g_best or (g == g_best and j < jb):
                    g_best = g
                    jb = j
        best[i] = g_best
        first[i] = jb


@compiled()
def _dilate(h, coefficients, dx, R, caps, e, off):  # pragma: no cover - compiled
    """``e_i`` by Newton on the profile's spline from the best sample; ``off_i`` its offset, m."""
    n = h.shape[0]
    R2 = R * R
    bests = np.empty(n)
    firsts = np.empty(n, dtype=np.int64)
    _best_samples(h, caps, bests, firsts)
    for i in range(n):
        best = bests[i]
        jb = firsts[i]
        x_best = jb * dx
        a = max(jb - 1, 0) * dx
        b = min(jb + 1, n - 1) * dx
        s = i * dx
        x = x_best
        for _ in range(NEWTON_ITERATIONS):
            d = x - s
            q = R2 - d * d
            if q <= 0.0:
                break
            _, h1, h2 = envelope_at(coefficients, dx, x)
            root = math.sqrt(q)
            g1 = h1 - d / root
            g2 = h2 - R2 / (q * root)
            if g2 >= 0.0:
                break
            x_new = x - g1 / g2
            if not a <= x_new <= b:
                break
            x = x_new
        d = x - s
        if d * d < R2:
            hx, _, _ = envelope_at(coefficients, dx, x)
            g = hx - (R - math.sqrt(R2 - d * d))
            if g > best:
                best = g
                x_best = x
        e[i] = best
        off[i] = x_best - s


@compiled()
def spline_piece(n, dx, s):  # pragma: no cover - compiled
    """The piece of ``n`` of length ``dx`` (m) holding ``s`` (m), the first or last beyond."""
    i = int(math.floor(s / dx))
    if i < 0:
        return 0
    if i > n - 1:
        return n - 1
    return i


@compiled()
def envelope_at(coefficients, dx, s):  # pragma: no cover - compiled
    """``(e, e', e'')`` (m, 1, 1/m) of the envelope's spline at ``s`` (m, in ``[0, (N-1) dx]``)."""
    i = spline_piece(coefficients.shape[0], dx, s)
    t = s - i * dx
    c0 = coefficients[i, 0]
    c1 = coefficients[i, 1]
    c2 = coefficients[i, 2]
    value = ((c0 * t + c1) * t + c2) * t + coefficients[i, 3]
    slope = (3.0 * c0 * t + 2.0 * c1) * t + c2
    curvature = 6.0 * c0 * t + 2.0 * c1
    return value, slope, curvature
