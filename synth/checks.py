"""Validation helpers shared by every public constructor, and options declared once on them.

A helper takes the dotted name, the value and the unit, and returns the value converted or
raises, never clamps: ``plate.thickness=-0.002 must be > 0 (metres)``. An :class:`Option` is a
frozen dataclass's field with its unit, values allowed, doc and check, read by every front end."""

from __future__ import annotations

import dataclasses
import difflib
import inspect
import math
import numbers
import os
import textwrap
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from synth.errors import ParameterError


def _unit(unit: str) -> str:
    return f" ({unit})" if unit else ""


def real(name: str, value: object, unit: str = "", allowed: str = "") -> float:
    """``value`` as a finite float, else ``ParameterError`` naming ``allowed`` (such as
    ``"> 0"``, the range the caller checks next)."""
    if type(value) is float:  # fast path for the common case
        if math.isfinite(value):
            return value
        raise ParameterError(_not_finite(name, value, unit, allowed))
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise ParameterError(
            f"{name}={value!r} must be a real number{' ' + allowed if allowed else ''}"
            f"{_unit(unit)}, not {type(value).__name__}"
        )
    x = float(value)
    if not math.isfinite(x):
        raise ParameterError(_not_finite(name, value, unit, allowed))
    return x


def _not_finite(name, value, unit, allowed) -> str:
    return f"{name}={value!r} must be finite{' and ' + allowed if allowed else ''}{_unit(unit)}"


def positive(name: str, value: object, unit: str = "") -> float:
    """A finite float ``> 0``."""
    x = real(name, value, unit, "> 0")
    if not x > 0.0:
        raise ParameterError(f"{name}={value!r} must be > 0{_unit(unit)}")
    return x


def positive_at_most(name: str, value: object, hi: float, unit: str = "") -> float:
    """A finite float ``> 0`` and ``<= hi`` (the documented upper end of its range)."""
    x = real(name, value, unit, f"> 0 and <= {hi:g}")
    if not 0.0 < x <= hi:
        raise ParameterError(f"{name}={value!r} must be > 0 and <= {hi:g}{_unit(unit)}")
    return x


def nonnegative(name: str, value: object, unit: str = "") -> float:
    """A finite float ``>= 0``."""
    x = real(name, value, unit, ">= 0")
    if not x >= 0.0:
        raise ParameterError(f"{name}={value!r} must be >= 0{_unit(unit)}")
    return x


def in_range(name, value, lo: float, hi: float, unit="", *, lo_open=True, hi_open=True) -> float:
    """A finite float inside an interval; open or closed at either end."""
    interval = f"in {'(' if lo_open else '['}{lo:g}, {hi:g}{')' if hi_open else ']'}"
    x = real(name, value, unit, interval)
    if not ((x > lo if lo_open else x >= lo) and (x < hi if hi_open else x <= hi)):
        raise ParameterError(f"{name}={value!r} must be {interval}{_unit(unit)}")
    return x


def choice(name: str, value: object, allowed: Iterable[str]) -> str:
    """One of a fixed set of strings."""
    allowed = tuple(allowed)
    if value not in allowed:
        raise ParameterError(f"{name}={value!r} must be one of {', '.join(map(repr, allowed))}")
    return value


def did_you_mean(name: str, allowed: Iterable[str], n: int = 1, cutoff: float = 0.6) -> str:
    """`` (did you mean 'x'?)`` naming the ``n`` allowed words nearest to ``name``, or ``""``."""
    near = difflib.get_close_matches(str(name), list(allowed), n=n, cutoff=cutoff)
    return f" (did you mean {', '.join(map(repr, near))}?)" if near else ""


def point(name: str, value: object, dims: int, unit: str = "metres") -> tuple[float, ...]:
    """A tuple of ``dims`` finite floats (a position)."""
    if type(value) is tuple and len(value) == dims:
        if all(type(v) is float and -math.inf < v < math.inf for v in value):
            return value  # finite floats already: nothing to convert
    try:
        items = tuple(value)
    except TypeError:
        raise ParameterError(
            f"{name}={value!r} must be a sequence of {dims} numbers ({unit})"
        ) from None
    if len(items) != dims:
        raise ParameterError(
            f"{name}={value!r} must have {dims} coordinates ({unit}), got {len(items)}"
        )
    axes = "xyz"
    return tuple(real(f"{name}.{axes[i]}", v, unit) for i, v in enumerate(items))


def audio_array(name: str, audio: object) -> np.ndarray:
    """A non-empty, finite float array ``(frames,)`` or ``(frames, channels)``, not copied
    where possible."""
    if audio is None or isinstance(audio, (str, bytes)):
        raise ParameterError(
            f"{name}={audio!r} must be a float array (frames,) or (frames, channels)"
        )
    try:
        a = np.asarray(audio)
    except Exception:  # noqa: BLE001 - any conversion failure is bad input
        raise ParameterError(f"{name} of type {type(audio).__name__} is not an array") from None
    if not np.issubdtype(a.dtype, np.floating):
        raise ParameterError(
            f"{name} has dtype {a.dtype}; it must be a float array (samples in units "
            f"of full scale, or physical units before normalize)"
        )
    if a.ndim not in (1, 2):
        raise ParameterError(
            f"{name} has shape {a.shape}; it must be (frames,) or (frames, channels)"
        )
    if a.size == 0:
        raise ParameterError(f"{name} has shape {a.shape}; it must not be empty")
    bad = np.flatnonzero(~np.isfinite(a.reshape(-1)))
    if bad.size:
        raise ParameterError(
            f"{name} has {bad.size} non-finite samples (first: flat index {bad[0]}, "
            f"value {a.reshape(-1)[bad[0]]!r}); every sample must be finite"
        )
    return a


def integer_at_least(name: str, value: object, least: int, what: str = "") -> int:
    """An integer ``>= least``; ``what`` it counts goes into the message."""
    if isinstance(value, bool) or not isinstance(value, numbers.Integral) or value < least:
        raise ParameterError(f"{name}={value!r} must be an integer >= {least}{_unit(what)}")
    return int(value)


def samplerate(value: object, name: str = "samplerate") -> int:
    """An integer sample rate ``> 0``, Hz."""
    if isinstance(value, bool) or not isinstance(value, numbers.Integral) or value <= 0:
        raise ParameterError(f"{name}={value!r} must be an integer > 0 (Hz)")
    return int(value)


def environment_integer(name: str, default: int, least: int = 0, unit: str = "") -> int:
    """The integer environment variable ``name`` (``>= least``), or ``default`` when unset
    or empty; else ``ParameterError`` naming the variable and its text."""
    text = os.environ.get(name)
    if text is None or not text.strip():
        return default
    try:
        value = int(text.strip())
    except ValueError:
        value = None
    if value is None or value < least:
        raise ParameterError(f"{name}={text!r} must be an integer >= {least}{_unit(unit)}")
    return value


def environment_directory(name: str):
    """The folder (``~`` expanded, perhaps not made yet) named by the environment variable
    ``name``, or None when unset or empty; ``ParameterError`` when it is a file (which
    would otherwise turn the folder's use off without a word)."""
    text = os.environ.get(name)
    if text is None or not text.strip():
        return None
    path = Path(text).expanduser()
    if path.exists() and not path.is_dir():
        raise ParameterError(
            f"{name}={text!r} must be a directory (created if missing), not a file; give a "
            f"folder or unset it"
        )
    return path


@dataclass(frozen=True)
class Option:
    """The declaration of one option (a field's metadata): its SI ``unit`` ("" for a count
    or a name), the values ``allowed`` as messages and docs state them, ``doc``, the command
    line's ``metavar``, ``check(name, value, checked)`` (the value converted, given the
    options checked before it), the ``choices`` of a choice, and ``parse`` from the command
    line's text (``bool``: a switch)."""

    unit: str
    allowed: str
    doc: str
    metavar: str
    check: Callable[[str, object, dict], object]
    choices: tuple[str, ...] | None = None
    parse: Callable[[str], object] = float


def option(default, **declaration):
    """A dataclass field declaring an option (:class:`Option`'s fields as keywords)."""
    kwargs = {} if default is dataclasses.MISSING else {"default": default}
    return field(metadata={"option": Option(**declaration)}, **kwargs)


def check_fields(instance) -> None:
    """Check and convert every field of the frozen ``instance`` in order."""
    checked: dict = {}
    for f in dataclasses.fields(instance):
        checked[f.name] = f.metadata["option"].check(f.name, getattr(instance, f.name), checked)
        object.__setattr__(instance, f.name, checked[f.name])


def names(cls) -> tuple[str, ...]:
    """The options of ``cls``, in the order of its fields."""
    return tuple(f.name for f in dataclasses.fields(cls))


def check_names(cls, given, what: str) -> None:
    """``TypeError`` naming the nearest option for a name of ``given`` not an option of ``cls``."""
    known = names(cls)
    for name in (n for n in given if n not in known):
        hint = did_you_mean(name, known)
        raise TypeError(f"{name!r} is not {what}{hint}; options: {', '.join(known)}")


def declaration(cls, name: str) -> Option:
    """The :class:`Option` of the option ``name`` of ``cls``."""
    return cls.__dataclass_fields__[name].metadata["option"]


def default(cls, name: str):
    """The default of the option ``name`` of ``cls`` (``inspect.Parameter.empty`` for none)."""
    value = cls.__dataclass_fields__[name].default
    return inspect.Parameter.empty if value is dataclasses.MISSING else value


def describe(cls, name: str) -> str:
    """``doc (unit; allowed)`` of the option ``name`` of ``cls``."""
    d = declaration(cls, name)
    return f"{d.doc} ({d.unit + '; ' if d.unit else ''}{d.allowed})"


def parameters_doc(cls, indent: str = "    ") -> str:
    """The options of ``cls`` as a numpydoc parameter list (name, type, default, doc)."""
    lines = []
    for f in dataclasses.fields(cls):
        value = default(cls, f.name)
        shown = "required" if value is inspect.Parameter.empty else f"default {value!r}"
        lines.append(f"{indent}{f.name} : {f.type}, {shown}")
        body = indent + "    "
        text = describe(cls, f.name) + "."
        lines.append(textwrap.fill(text, 92, initial_indent=body, subsequent_indent=body))
    return "\n".join(lines)


def keyword_parameters(cls) -> list[inspect.Parameter]:
    """The options of ``cls`` as keyword-only parameters (for a generated signature)."""
    return [
        inspect.Parameter(name, inspect.Parameter.KEYWORD_ONLY, default=default(cls, name))
        for name in names(cls)
    ]
