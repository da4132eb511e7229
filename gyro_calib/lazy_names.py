"""Names a package re-exports, imported on first use (PEP 562).

A package whose ``__init__`` would otherwise import every submodule (NumPy, YAML, the bag
reader) keeps a table name → submodule and answers ``package.name`` from it, so a command's
``--help`` loads none of them. Standard library only.
"""

from __future__ import annotations

import importlib
from typing import Any


def resolve(package: str, where: dict[str, str], name: str, namespace: dict[str, Any]) -> Any:
    """``package.name``: from its submodule ``where[name]``, or the submodule ``name`` itself.

    The value is stored in ``namespace`` (the package's globals), so the next use is a plain
    attribute.

    Raises:
        AttributeError: neither a re-exported name nor a submodule.
    """
    module = where.get(name)
    if module is None:
        try:
            return importlib.import_module(f'{package}.{name}')
        except ModuleNotFoundError as exc:
            if exc.name != f'{package}.{name}':
                raise
        raise AttributeError(f'module {package!r} has no attribute {name!r}')
    value = getattr(importlib.import_module(module), name)
    namespace[name] = value
    return value
