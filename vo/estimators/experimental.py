"""Experimental estimator options: measured, non-default alternatives kept for the study that measured them.

An estimator's configuration (``RopConfig``, ``VinsConfig``) names a set of its fields experimental. Given as
options (``--opt``, YAML, constructor keywords) they take the prefix ``experimental.``: ``--opt
experimental.rop_loss=tukey``, ``{"experimental.rop_loss": "tukey"}`` or a nested ``{"experimental": {"rop_loss":
"tukey"}}``. The bare name of an experimental field is refused with a line that says how to give it, so a
result obtained with one is never mistaken for the product's. docs/estimators.md ("Experimental options")
lists them with the study behind each.
"""
from __future__ import annotations

from collections.abc import Mapping

from vo.errors import EstimatorError

PREFIX = "experimental."


def resolve_experimental(options: dict, experimental, owner: str) -> dict:
    """``options`` with experimental fields (``experimental.<field>`` keys, or an ``experimental`` mapping)
    renamed to their field names. A bare experimental field, or an ``experimental.`` key that is not one of
    ``experimental`` -> :class:`EstimatorError` naming ``<owner>.<key>``."""
    out, given = {}, {}
    for key, value in dict(options or {}).items():
        if key == "experimental":
            if not isinstance(value, Mapping):
                raise EstimatorError(f"{owner}.experimental: expected a mapping of experimental options, "
                                     f"got {type(value).__name__}")
            given.update(value)
        elif isinstance(key, str) and key.startswith(PREFIX):
            given[key[len(PREFIX):]] = value
        elif key in experimental:
            raise EstimatorError(f"{owner}.{key}: an experimental option (docs/estimators.md, \"Experimental "
                                 f"options\"); give it as {PREFIX}{key}")
        else:
            out[key] = value
    for key, value in given.items():
        if key not in experimental:
            raise EstimatorError(f"{owner}.{PREFIX}{key}: not an experimental option; experimental: "
                                 f"{', '.join(sorted(experimental))}")
        out[key] = value
    return out
