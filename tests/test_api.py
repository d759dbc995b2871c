"""The package's public names: what other code imports from ``synth``."""

import inspect

import pytest

import synth
from synth import contact, materials

# Names that UI, game and batch code rely on (README, Python API).
PUBLIC = [
    "Material",
    "Ball",
    "HollowBall",
    "Plate",
    "Scene",
    "Contact",
    "Accelerometer",
    "Microphone",
    "Rayleigh",
    "LossFactor",
    "solve_impact",
    "solve_contact",
    "simulate_bounces",
    "simulate_scene",
    "ImpactResult",
    "BounceSequence",
    "Impact",
    "render",
    "Render",
    "RenderOptions",
    "RenderInfo",
    "load_preset",
    "write_audio",
    "read_audio",
    "play",
    "analyze",
    "analyze_file",
    "Analysis",
    "AnalysisOptions",
    "Tick",
    "SynthError",
    "ParameterError",
]


@pytest.mark.parametrize("name", PUBLIC)
def test_public_name_is_exported(name):
    # Each name is importable from the package and listed in __all__.
    assert hasattr(synth, name) and name in synth.__all__


def test_public_name_is_exported_rejects_unknown_name():
    # A name that is not part of the API is not there by accident.
    with pytest.raises(AttributeError):
        synth.solve_everything  # noqa: B018


def test_modules_are_exported():
    assert synth.contact is contact and synth.materials is materials
    assert callable(synth.plate.modes)


def test_error_tree():
    # ParameterError is a SynthError and a ValueError, so generic callers can catch it.
    assert issubclass(synth.ParameterError, synth.SynthError)
    assert issubclass(synth.ParameterError, ValueError)
    with pytest.raises(ValueError, match=r"speed=-1\.0 must be > 0 \(m/s\)"):
        synth.solve_contact(mass=0.004, stiffness=1e9, admittance=1e-3, speed=-1.0)


@pytest.mark.parametrize(
    "func, keywords",
    [
        (
            synth.solve_contact,
            [
                "mass",
                "stiffness",
                "admittance",
                "speed",
                "gravity",
                "exponent",
                "dissipation",
                "plate_velocity",
                "rtol",
            ],
        ),
        (synth.solve_impact, ["position", "gravity", "contact", "rtol"]),
        (synth.simulate_bounces, ["drop_height", "position", "gravity"]),
        (synth.render, ["samplerate", "normalize"]),
    ],
)
def test_keyword_only_arguments(func, keywords):
    # The documented keyword arguments exist and are keyword-only (no positional drift).
    params = inspect.signature(func).parameters
    for k in keywords:
        assert params[k].kind is inspect.Parameter.KEYWORD_ONLY, (func.__name__, k)


def test_defaults_of_the_documented_signatures():
    sig = inspect.signature(synth.solve_contact).parameters
    assert (
        sig["gravity"].default,
        sig["exponent"].default,
        sig["dissipation"].default,
        sig["plate_velocity"].default,
        sig["rtol"].default,
    ) == (9.81, 1.5, 0.0, 0.0, 1e-6)
    sig = inspect.signature(synth.solve_impact).parameters
    # contact=None: the ball's own law (Hertz for a solid ball, the shell law for a hollow one)
    assert (
        sig["position"].default,
        sig["gravity"].default,
        sig["contact"].default,
        sig["rtol"].default,
    ) == (None, 9.81, None, 1e-6)
    sig = inspect.signature(synth.render).parameters
    # no default rate: the caller names it
    assert (sig["samplerate"].default, sig["normalize"].default) == (
        inspect.Parameter.empty,
        "peak",
    )
    assert sig["samplerate"].kind is inspect.Parameter.KEYWORD_ONLY


def test_scene_takes_the_drop_by_keyword():
    # Scene(ball, plate, *, drop_height, position=None, listener=None, gravity=9.81)
    params = inspect.signature(synth.Scene).parameters
    assert [p for p in params][:2] == ["ball", "plate"]
    for k in ("drop_height", "position", "listener", "gravity"):
        assert params[k].kind is inspect.Parameter.KEYWORD_ONLY
    assert (params["position"].default, params["listener"].default, params["gravity"].default) == (
        None,
        None,
        9.81,
    )
    with pytest.raises(TypeError):
        synth.Scene(synth.Ball("steel", 0.005), synth.Plate("mdf-18", 0.018, 1.2, 0.5), 0.1)


def test_version_is_declared_once():
    # pyproject.toml reads the version from synth.__version__ (setuptools dynamic), so the
    # installed metadata and the package agree.
    from importlib.metadata import version

    assert version("impact-synth") == synth.__version__
