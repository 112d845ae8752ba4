"""Modules loaded on first use, so that ``pen --help`` does not pay for numpy and the API.

``np = lazy("numpy")`` gives a module object whose body runs the first time one of its attributes is
read; a module that is already imported is returned as it is.  The standard library's
:class:`importlib.util.LazyLoader` does the work (the scientific-Python "SPEC 1" pattern).
"""

from __future__ import annotations

import importlib
import importlib.util
import sys
from types import ModuleType


def lazy(name: str) -> ModuleType:
    """The module ``name``, executed when first used."""
    if name in sys.modules:
        return sys.modules[name]
    spec = importlib.util.find_spec(name)
    if spec is None or spec.loader is None:
        raise ModuleNotFoundError(f"No module named {name!r}", name=name)
    loader = importlib.util.LazyLoader(spec.loader)
    spec.loader = loader
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    loader.exec_module(module)
    parent, _, child = name.rpartition(".")
    if parent:  # as an import would: ``pencli.api`` is an attribute of ``pencli``
        setattr(importlib.import_module(parent), child, module)
    return module
