"""Public names of a package imported on first use (PEP 562), so that importing the package,
or one light submodule of it (its options' declaration, read by the command line), loads
none of its numerical code."""

from __future__ import annotations

import importlib
import sys


def lazy_names(package: str, table: dict[str, str], submodules: dict | None = None):
    """``__getattr__`` and ``__dir__`` for ``package``: each name of ``table`` is taken from
    its submodule (the table's value, below ``package``) on first use; a name of
    ``submodules`` is that submodule (None: any other name is the submodule of its name)."""
    module = sys.modules[package]

    def __getattr__(name):
        if name in table:
            value = getattr(importlib.import_module(f"{package}.{table[name]}"), name)
        elif submodules is not None:
            if name not in submodules:
                raise AttributeError(f"module {package!r} has no attribute {name!r}")
            value = importlib.import_module(f"{package}.{submodules[name]}")
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
        return sorted(set(vars(module)) | set(table) | set(submodules or ()))

    return __getattr__, __dir__
