"""The engine's exceptions. ``ParameterError`` (bad input) is also a ``ValueError``; numerical
trouble inside a solver is reported in its result (``success``, ``status``), never raised."""


class SynthError(Exception):
    """Root of every error the engine raises on purpose."""


class ParameterError(SynthError, ValueError):
    """Bad input: the message names the field, its value and what is allowed."""
