"""Lazy public names: a namespace module lists ``{module: (names...)}`` and its names are
imported from their modules on first use, so ``import surfhap`` (and each namespace) stays
cheap: numba, scipy, trimesh and matplotlib load only when a name that needs them is touched."""

from __future__ import annotations

from importlib import import_module

__all__ = ["lazy_names"]


def lazy_names(namespace: str, modules: dict[str, tuple[str, ...]], namespace_globals: dict):
    """(``__getattr__``, ``__dir__``) for the module ``namespace`` whose public names are
    ``modules`` ({defining module: names}); a name is cached in ``namespace_globals`` once loaded."""
    where = {name: module for module, names in modules.items() for name in names}

    def __getattr__(name: str):
        module = where.get(name)
        if module is None:
            raise AttributeError(f"module {namespace!r} has no attribute {name!r}")
        value = getattr(import_module(module), name)
        namespace_globals[name] = value
        return value

    def __dir__():
        return sorted(set(namespace_globals) | set(where))

    return __getattr__, __dir__
