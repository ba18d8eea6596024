"""Subcommands of the ``arstream`` CLI, one module each.

A command module defines ``register(subparsers)``, which adds its parser and
sets ``func`` (called with the parsed namespace, returns an exit code), and
an integer ``ORDER`` that places it in ``arstream --help``. Modules whose
name starts with ``calib_`` are sub-commands of ``arstream calib`` instead.
The CLI discovers the modules itself: adding a command means adding a file.
"""

from __future__ import annotations

import importlib
import pkgutil
from types import ModuleType


def discover(prefix: str = "") -> list[ModuleType]:
    """Command modules of this package whose names start with ``prefix``
    (top-level commands: those not starting with ``calib_``), in ``ORDER``."""
    mods = []
    for info in pkgutil.iter_modules(__path__):
        name = info.name
        if name.startswith("_"):
            continue
        if prefix and not name.startswith(prefix):
            continue
        if not prefix and name.startswith("calib_"):
            continue
        mod = importlib.import_module(f"{__name__}.{name}")
        if hasattr(mod, "register"):
            mods.append(mod)
    return sorted(mods, key=lambda m: (getattr(m, "ORDER", 100), m.__name__))
