"""Plug-in classes named ``"package.module:Class"`` (user scenes, estimators): one loader for every kind."""
from __future__ import annotations

import importlib


def load_plugin_class(path: str, base: type, kind: str, error: type) -> type:
    """``"package.module:Class"`` -> the class, which must subclass ``base``; anything else raises a
    one-line ``error`` naming the ``kind`` (e.g. "scene", "estimator") and the path."""
    module, _, attr = str(path).partition(":")
    if not module or not attr:
        raise error(f"{kind} {path!r}: expected 'package.module:Class'")
    try:
        cls = getattr(importlib.import_module(module), attr)
    except ImportError as e:
        raise error(f"{kind} {path!r}: cannot import module {module!r} ({e})") from None
    except AttributeError:
        raise error(f"{kind} {path!r}: module {module!r} has no attribute {attr!r}") from None
    if not (isinstance(cls, type) and issubclass(cls, base)):
        raise error(f"{kind} {path!r}: not a subclass of {base.__module__}.{base.__qualname__}")
    return cls
