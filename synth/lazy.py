"""Public names of a package imported on first use (PEP 562), so that importing the package,
or one light submodule of it (its options' declaration, read by the command line), loads
none of its numerical code."""

from __future__ import annotations

import importlib
import sys


def lazy_names(package: str, table: dict[str, str]):
    """``__getattr__`` and ``__dir__`` for ``package``: each name of ``table`` is taken from
    its submodule (the table's value) on first use; any other name is a submodule."""
    module = sys.modules[package]

    def __getattr__(name):
        if name in table:
            value = getattr(importlib.import_module(f"{package}.{table[name]}"), name)
        else:
            try:
                value = importlib.import_module(f"{package}.{name}")
            except ModuleNotFoundError as exc:
                if exc.name != f"{package}.{name}":  # a module it needs is missing
                    raise
                raise AttributeError(f"module {package!r} has no attribute {name!r}") from None
        setattr(module, name, value)
        return value

    def __dir__():
        return sorted(set(vars(module)) | set(table))

    return __getattr__, __dir__
