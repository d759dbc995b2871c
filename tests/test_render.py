"""Modal synthesis and rendering (docs/physics.md, "Modal synthesis")."""

import dataclasses
import math

import numpy as np
import pytest
from reference import pulse_transforms

import synth
from synth.errors import ParameterError
from synth.physics import modes as plate_modes
from synth.physics.scene import Accelerometer, Microphone, Scene
from synth.sound.modal_bank import Bank, synthesize
from synth.sound.render import render


@pytest.fixture(scope="module")
def default():
    """The default scene under the thesis' model (Hertz pulses; the measured model's
    viscoelastic pulse is checked in tests/test_contact_viscoelastic.py)."""
    return synth.load_preset("default", ["contact.model=thesis"])


EXACT = dict(normalize="none", floor_db=-200.0, fade=0.0)  # no omission, no fade


def accel_scene(base, **kw):
    return Scene(
        base.ball,
        base.plate,
        drop_height=0.1,
        position=base.position,
        listener=Accelerometer((0.5, 0.2)),
        **kw,
    )


@pytest.fixture(scope="module")
def default_render(default):
    return render(default, samplerate=48000)


def test_render_default_preset(default_render):
    # The main job: a normalised mono float32 signal at -1 dBFS peak (1e-6), 82 ticks.
    r = default_render
    assert r.audio.dtype == np.float32 and r.audio.ndim == 1
    assert r.samplerate == 48000 and r.units == "Pa"
    assert np.max(np.abs(r.audio)) == pytest.approx(10 ** (-1 / 20), rel=1e-6)
    assert len(r.impacts) > 10
    assert np.all(np.isfinite(r.audio))


def test_render_info_is_typed_and_settings_is_its_view(default_render):
    # The render's options and figures in a RenderInfo (options checked, max_frequency the
    # Nyquist frequency it rendered to); Render.settings is the same, flat and read-only.
    info = default_render.info
    assert isinstance(info, synth.RenderInfo) and isinstance(info.options, synth.RenderOptions)
    assert info.options.max_frequency == 24000.0 and info.path is None
    assert info.n_impacts == len(default_render.impacts) and 0 < info.n_modes_rendered
    settings = default_render.settings
    assert settings["max_frequency"] == 24000.0 and settings["n_modes"] == info.n_modes
    assert settings["listener_position"] == list(info.listener_position)
    with pytest.raises(TypeError):
        settings["peak_db"] = 0.0  # type: ignore[index]


def test_render_takes_options_as_one_object(default):
    # render(scene, options=RenderOptions(...)) is render(scene, **fields): the same samples
    o = synth.RenderOptions(samplerate=8000, max_frequency=2000.0, max_tail=0.5, **EXACT)
    a = render(accel_scene(default), options=o)
    b = render(accel_scene(default), samplerate=8000, max_frequency=2000.0, max_tail=0.5, **EXACT)
    assert np.array_equal(a.audio, b.audio)
    assert a.info == dataclasses.replace(b.info, bank_seconds=a.info.bank_seconds)
    c = render(accel_scene(default), options=o, max_tail=0.01)  # a keyword changes one option
    assert c.info.options.max_tail == 0.01 and c.audio.size < a.audio.size


def test_first_tick_is_causal_to_the_sample(default):
    # Nothing before the first touch reaches the listener: every sample before the onset
    # (first touch + travel time) is exactly 0, and the first sample after it is not.
    r = render(accel_scene(default), samplerate=48000, **EXACT)
    t0 = r.onsets[0]
    first = math.ceil(t0 * r.samplerate)
    assert np.all(r.audio[:first] == 0.0)
    assert r.audio[first] != 0.0
    assert t0 == pytest.approx(r.settings["preroll"], abs=1e-12)


def test_each_impact_starts_at_its_onset(default):
    # Superposition: the audio of the first n impacts minus that of the first n-1 is impact
    # n's contribution, exactly 0 before its onset (to rounding, 1e-9 of the peak) and
    # present from the first sample after it: onsets placed to the sample (well within the
    # required 0.1 ms), for the first ten impacts.
    scene = accel_scene(default)
    seq = synth.simulate_scene(scene)
    full = render(scene, samplerate=48000, sequence=seq, **EXACT)
    peak = np.max(np.abs(full.audio))
    prev = None
    for n in range(1, 11):
        part = synth.BounceSequence(seq.impacts[:n], seq.stop_reason, seq.drop_height, seq.gravity)
        r = render(scene, samplerate=48000, sequence=part, **EXACT)
        if prev is not None:
            L = min(r.audio.size, prev.size)
            diff = r.audio[:L].astype(float) - prev[:L]
            onset = r.onsets[n - 1]
            first = math.ceil(onset * 48000)
            assert np.max(np.abs(diff[:first])) <= 1e-6 * peak
            assert abs(diff[first]) > 1e-6 * peak
        prev = r.audio.astype(float)


def test_ringing_matches_the_continuous_response_at_subsample_onsets(default):
    # The bank samples the exact continuous-time ringing sum_k Re[C_k e^(p_k (t - t0))]:
    # with an onset 0.37 samples off the grid, samples after the contact agree with the
    # closed form to 1e-9 of the peak.
    seq = synth.simulate_scene(default, max_impacts=1)
    res = seq[0].result
    modes = plate_modes.modes(default.plate, max_frequency=5000.0)
    sig = np.asarray(modes.decay_rates)
    wd = np.sqrt(np.asarray(modes.angular_frequencies) ** 2 - sig**2)
    poles = -sig + 1j * wd
    b = modes.shapes(np.array([default.position]))[0] / np.asarray(modes.modal_masses)
    out_gain = modes.shapes(np.array([[0.3, 0.1]]))[0] * poles**2
    fs = 48000.0
    t0 = (1000 + 0.37) / fs
    audio, info = synthesize(
        [res], np.array([t0]), Bank(poles, b, out_gain, fs), floor=1e-20, max_samples=4000
    )
    L = pulse_transforms(res, poles)
    C = -1j * b / wd * out_gain * L
    s = np.arange(1010, 1400)
    exact = np.array([np.sum((C * np.exp(poles * (n / fs - t0))).real) for n in s])
    assert np.max(np.abs(audio[s] - exact)) <= 1e-9 * np.max(np.abs(exact))


def test_modal_energy_equals_energy_sent_into_plate(default):
    # Energy balance between contact and modes: right after a mid-plate impact the modes
    # hold sum_k M_k |p_k A_k|^2 / 2, and the contact sent beta Int F^2 dt into the plate.
    # No wave returns from the edges during the 0.1 ms contact, so the two agree; 5 %
    # allows for the finite plate's rigid-body motion (not a bending mode) and for the
    # modes above 24 kHz.
    res = synth.simulate_scene(default, max_impacts=1)[0].result
    modes = plate_modes.modes(default.plate, max_frequency=24000.0)
    sig = np.asarray(modes.decay_rates)
    wd = np.sqrt(np.asarray(modes.angular_frequencies) ** 2 - sig**2)
    poles = -sig + 1j * wd
    M = np.asarray(modes.modal_masses)
    b = modes.shapes(np.array([default.position]))[0] / M
    amps = pulse_transforms(res, poles)
    A = -1j * b / wd * amps
    energy = 0.5 * np.sum(M * np.abs(poles * A) ** 2)
    assert energy == pytest.approx(res.plate_energy, rel=0.05)


@pytest.mark.filterwarnings("ignore::scipy.integrate.IntegrationWarning")
@pytest.mark.parametrize(
    "preset", ["default", "small-click-on-acrylic", "rubber-ball-on-wooden-floor"]
)
def test_pulse_transforms_against_adaptive_quadrature(preset):
    # L_k = Int_0^tau F(u) exp(-p_k u) du by the renderer's rule against scipy's adaptive
    # quadrature (QUADPACK) of the same dense force output. The plain trapezoid rule errs
    # by C h^(n+1) (n = 3/2: 1.5e-5 of the impulse for the thesis pulse on 65 points);
    # the extrapolated rule leaves O(|p| h^(n+2)): at most 2e-6 of the impulse up to
    # 23 kHz and 1e-7 up to 1 kHz, for pulses of 25 us (acrylic), 0.1 ms (thesis) and
    # 1.6 ms (rubber).
    from scipy.integrate import quad

    scene = synth.load_preset(preset, ["contact.model=thesis"])  # Hertz pulses
    res = synth.simulate_scene(scene, max_impacts=1)[0].result
    tau, J = res.contact_time, res.impulse
    freqs = np.array([100.0, 1000.0, 3000.0, 8000.0, 15000.0, 23000.0])
    poles = -30.0 + 2j * np.pi * freqs
    L = pulse_transforms(res, poles, omega_max=2 * np.pi * 24000.0)
    for p, f, got in zip(poles, freqs, L):
        parts = [
            quad(
                lambda u, c=c: res.force_at(u) * np.exp(-p.real * u) * c(-p.imag * u),
                0.0,
                tau,
                epsabs=1e-16 * J,
                epsrel=1e-12,
                limit=1000,
            )[0]
            for c in (np.cos, np.sin)
        ]
        err = abs(got - complex(*parts)) / J
        assert err <= (1e-7 if f <= 1000.0 else 2e-6), (preset, f, err)


def test_samplerate_invariance_48_96(default):
    # Same band (modes to 20 kHz), no omission: the 96 kHz render sampled every other
    # sample is the 48 kHz render (the same continuous signal; 1e-6 of the peak).
    a = render(accel_scene(default), samplerate=48000, max_frequency=20000.0, **EXACT)
    b = render(accel_scene(default), samplerate=96000, max_frequency=20000.0, **EXACT)
    L = min(a.audio.size, b.audio[::2].size)
    peak = np.max(np.abs(a.audio))
    assert np.max(np.abs(a.audio[:L] - b.audio[::2][:L])) <= 1e-6 * peak


def test_samplerate_invariance_44k1(default):
    # 44.1 kHz against 48 kHz, same band (modes to 15 kHz), no omission: both sample the
    # same continuous signal, so at the instants they share (every 147th sample at
    # 44.1 kHz is every 160th at 48 kHz: n / 300 s) they agree to 1e-6 of the peak (the
    # transforms' grids and the float32 output differ).
    a = render(accel_scene(default), samplerate=48000, max_frequency=15000.0, **EXACT)
    b = render(accel_scene(default), samplerate=44100, max_frequency=15000.0, **EXACT)
    assert a.settings["audio_start"] == pytest.approx(b.settings["audio_start"], abs=1e-15)
    n = min(a.audio.size // 160, b.audio.size // 147)
    xa = a.audio[::160][:n].astype(float)
    xb = b.audio[::147][:n].astype(float)
    peak = np.max(np.abs(a.audio))
    assert np.max(np.abs(xa - xb)) <= 1e-6 * peak
    assert np.max(np.abs(xa)) > 0.1 * peak


def test_no_mode_at_or_above_nyquist(default):
    # Alias-free by construction: at 8 kHz only modes below 4 kHz are rendered.
    r = render(default, samplerate=8000, normalize="none")
    below = plate_modes.modes(default.plate, max_frequency=4000.0 * (1 - 1e-9))
    assert r.settings["n_modes"] <= len(below)
    assert r.settings["max_frequency"] <= 4000.0


def test_tick_energy_falls_by_e_squared(default):
    # docs/physics.md, "Bounces": the tick energy falls by about e^2 per bounce. Each tick's energy
    # (its own contribution, by superposition) over the previous one's, against e^2 of
    # the impact between them, within 15 % (the pulse shortens as the speed falls, which
    # shifts the spectrum: "about").
    scene = accel_scene(default)
    seq = synth.simulate_scene(scene, max_impacts=6)
    energies = []
    for i in range(5):
        one = synth.BounceSequence((seq.impacts[i],), "max-impacts", seq.drop_height, seq.gravity)
        r = render(scene, samplerate=48000, sequence=one, **EXACT)
        energies.append(float(np.sum(r.audio.astype(float) ** 2)))
    for i in range(4):
        e = seq[i].result.restitution
        assert energies[i + 1] / energies[i] == pytest.approx(e**2, rel=0.15)


def test_settled_scene_renders():
    # A heavy ball that settles (lambda >> 1) still renders a finite, non-silent thud.
    s = Scene(
        synth.Ball("steel", 0.02),
        synth.Plate("aluminium", 0.001, 0.6, 0.5),
        drop_height=0.05,
        listener=Accelerometer((0.3, 0.25)),
        contact=synth.Contact(model="thesis"),  # the impedance plate: lambda >> 1 settles
    )
    r = render(s, samplerate=48000, normalize="none", max_frequency=5000.0)
    assert r.impacts[0].result.settled
    assert np.all(np.isfinite(r.audio)) and np.max(np.abs(r.audio)) > 0


@pytest.mark.parametrize(
    "kw, word",
    [
        (dict(samplerate=0), "samplerate"),
        (dict(samplerate=44100.5), "samplerate"),
        (dict(samplerate="48000"), "samplerate"),
        (dict(samplerate=1_000_000), "samplerate"),
        (dict(normalize="loud"), "normalize"),
        (dict(floor_db=3.0), "floor_db"),
        (dict(max_frequency=-1.0), "max_frequency"),
        (dict(preroll=-0.1), "preroll"),
        (dict(fade=float("nan")), "fade"),
        (dict(sequence="x"), "sequence"),
    ],
)
def test_render_rejects_bad_input(kw, word, default):
    with pytest.raises(ParameterError, match=word):
        render(default, **{"samplerate": 48000, **kw})


def test_render_rejects_non_scene():
    with pytest.raises(ParameterError, match="scene"):
        render("default", samplerate=48000)


@pytest.mark.parametrize(
    "preset, floor_db", [("default", -40.0), ("default", -60.0), ("small-click-on-acrylic", -40.0)]
)
def test_omissions_stay_within_the_floor(preset, floor_db):
    # The omission budget (synth.sound.modal_bank): at every sample, the modes and tails left out
    # add up to at most floor * reference, for any number of impacts (the acrylic click
    # has dozens). Against the same render with nothing left out (floor -200 dB), fade off.
    scene = synth.load_preset(preset)
    seq = synth.simulate_scene(scene)
    full = render(scene, samplerate=48000, sequence=seq, **EXACT)
    cut = render(
        scene, samplerate=48000, sequence=seq, normalize="none", floor_db=floor_db, fade=0.0
    )
    ref = cut.settings["reference_amplitude"]
    a = np.pad(cut.audio.astype(float), (0, max(0, full.audio.size - cut.audio.size)))
    diff = np.abs(a[: full.audio.size] - full.audio.astype(float))
    # float32 output: the audio's own rounding (6e-8 of its peak) is allowed on top
    assert np.max(diff) <= 10 ** (floor_db / 20) * ref + 1e-7 * np.max(np.abs(full.audio))
    assert cut.settings["mode_samples"] < full.settings["mode_samples"]


def test_render_rejects_max_frequency_above_nyquist(default):
    with pytest.raises(ParameterError, match=r"max_frequency=30000.0 must be <= the Nyquist"):
        render(default, samplerate=48000, max_frequency=30000.0)


@pytest.mark.slow
def test_tail_cut_is_reported(default):
    # A steel plate (loss factor 1e-4) rings for tens of seconds: a 0.2 s max_tail cuts it,
    # and the render says so, with the bound of what rings on after the end.
    scene = synth.load_preset("steel-ball-on-steel-sheet")
    r = render(scene, samplerate=48000, max_tail=0.2, normalize="none")
    assert r.settings["tail_cut"] and r.settings["left_at_end"] > 10 ** (-80 / 20)
    r = render(default, samplerate=48000, normalize="none")
    assert not r.settings["tail_cut"]


def test_microphone_gain_is_the_least_squares_fit_of_the_causal_pressure():
    # A strongly damped mode (1/sigma = 40 us, shorter than the 0.3 ms spread of arrival
    # times over the plate) heard from the side: the causal pressure, simulated in the
    # time domain from 250 000 plate elements each heard from its own arrival on, is
    # fitted by G exp(p t) from the first arrival; the renderer's gain (the Rayleigh gain
    # at the mirror pole) is that fit within 1e-3 (the elements' and time grid's
    # discretisation), and the gain at the pole itself, which weights far elements by
    # exp(sigma (R - R0) / c) ~ e^3, fits far worse.
    from synth.sound import radiation as R
    from synth.sound.listener import AIR_DENSITY, SOUND_SPEED, _microphone_gains

    plate = synth.Plate("steel", 0.001, 0.12, 0.1, "simply-supported")
    modes = plate_modes.modes(plate, max_frequency=20000.0)
    k = 2
    om = np.asarray(modes.angular_frequencies)
    poles = -25000.0 + 1j * om
    listener = (0.2, 0.03, 0.03)
    scene = Scene(
        synth.Ball("steel", 0.002), plate, drop_height=0.01, listener=Microphone(listener)
    )
    kmax = (om.max() ** 2 * plate.surface_density / plate.flexural_rigidity) ** 0.25
    G = _microphone_gains(modes, scene.plate, scene.listener, poles, kmax)[k]
    # time domain: elements on a 500 x 500 midpoint grid, pressure per unit modal velocity
    n = 500
    xs = (np.arange(n) + 0.5) * 0.12 / n
    ys = (np.arange(n) + 0.5) * 0.1 / n
    X, Y = np.meshgrid(xs, ys, indexing="ij")
    pts = np.column_stack([X.ravel(), Y.ravel()])
    phi = modes.shapes(pts)[:, k]
    Rj = np.sqrt((pts[:, 0] - listener[0]) ** 2 + (pts[:, 1] - listener[1]) ** 2 + listener[2] ** 2)
    R0 = np.sqrt((listener[0] - 0.12) ** 2 + listener[2] ** 2)
    p = poles[k]
    c = AIR_DENSITY * p / (2 * np.pi) * phi / Rj * (0.12 * 0.1 / n**2)
    tau = (Rj - R0) / SOUND_SPEED
    order = np.argsort(tau)
    t = np.linspace(0.0, tau.max() + 30.0 / 25000.0, 200001)
    cum = np.concatenate([[0.0], np.cumsum(c[order] * np.exp(-p * tau[order]))])
    pressure = np.exp(p * t) * cum[np.searchsorted(tau[order], t, side="right")]
    basis = np.exp(p * t)
    fit = np.trapezoid(pressure * np.conj(basis), t) / np.trapezoid(np.abs(basis) ** 2, t)
    assert abs(G - fit) <= 1e-3 * abs(fit)
    pole_gain = R.rayleigh_gains(
        modes.shapes, (0.12, 0.1), listener, poles, max_wavenumber=kmax, reference_distance=R0
    )[k]

    def misfit(g):
        return np.trapezoid(np.abs(pressure - g * basis) ** 2, t)

    assert misfit(G) < 0.5 * misfit(pole_gain)
    assert abs(pole_gain) > 5 * abs(G)
