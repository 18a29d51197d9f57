"""Deprecated import paths, kept working scipy-style for one release cycle.

A module that moved leaves a small module at its old path whose ``__getattr__`` hands out the
public names of the new module with a :class:`DeprecationWarning` that names the new path and
the release that removes the old one. Private names are not forwarded.
"""

from __future__ import annotations

import importlib
import warnings
from collections.abc import Callable, Mapping, Sequence

#: The release that removes the deprecated import paths.
REMOVAL_VERSION = "0.3.0"


def deprecated_module(old: str, new: str, names: Sequence[str], *,
                      elsewhere: Mapping[str, str] | None = None,
                      ) -> tuple[Callable[[str], object], Callable[[], list[str]]]:
    """``__getattr__`` and ``__dir__`` for the module left at a deprecated import path.

    Parameters
    ----------
    old, new : str
        Dotted module paths: where the names were, and where they are now.
    names : sequence of str
        The public names the old module offered that are now in ``new``.
    elsewhere : mapping of str to str, optional
        Public names the old module offered that moved to other modules: name -> module.

    Returns
    -------
    (callable, callable)
        Module-level ``__getattr__(name)`` and ``__dir__()``.
    """
    where = {name: new for name in names}
    where.update(elsewhere or {})
    public = tuple(sorted(where))

    def __getattr__(name: str) -> object:
        if name not in where:
            raise AttributeError(f"module {old!r} has no attribute {name!r}")
        warnings.warn(f"{old} is deprecated and will be removed in simplexspline "
                      f"{REMOVAL_VERSION}: import {name} from {where[name]}",
                      DeprecationWarning, stacklevel=2)
        # Imported on use: the old path must not load the new module (or its optional
        # dependencies) before a name is asked for.
        return getattr(importlib.import_module(where[name]), name)

    def __dir__() -> list[str]:
        return list(public)

    return __getattr__, __dir__
