"""Estimator registry: names -> lazily imported classes, user plug-in class paths, external commands.

Accepted specs: a registered name (:data:`ESTIMATORS`), ``"package.module:Class"`` (a subclass of
:class:`vo.estimators.base.Estimator`), or ``"cmd:<template>"`` for an external program (see
:mod:`vo.estimators.external`). An estimator that reads ground truth declares it (:func:`is_oracle`).
"""
from __future__ import annotations

from rigs.plugins import load_plugin_class
from vo.errors import EstimatorError
from vo.estimators.base import Estimator
from vo.estimators.external import ExternalCommand, ExternalCommandError  # noqa: F401 - part of this API

ESTIMATORS = {
    "rop": "vo.rop.estimator:RopEstimator",
    "klt-pnp": "vo.estimators.pnp:KltPnpEstimator",
    "orb-pnp": "vo.estimators.orb_pnp:OrbPnpEstimator",
    "vins": "vo.vins.estimator:VinsEstimator",
}
# names that are a registered estimator with fixed options: seed 002's VINS configurations are ``vins`` with its
# ``preset`` option (vo.vins.vins_config.PRESETS), registered under these names too
FIXED_OPTIONS = {f"vins-{p}": ("vins", {"preset": p}) for p in ("ac-gf", "ac", "ac-me", "huber", "oracle")}
ESTIMATORS.update({name: ESTIMATORS[base] for name, (base, _) in FIXED_OPTIONS.items()})
FORMS = "a registered name, 'package.module:Class', or 'cmd:<command with {dataset} and {out}>'"
# one line each for `vo-testbed list`; a name without one shows its class docstring's first sentence
DESCRIPTIONS = {
    "rop": "seed 000: stereo VO by relative-orientation-parameter (ROP) adjustment, with propagated covariance",
    "klt-pnp": "seed 003: KLT optical-flow tracking on a feature grid, stereo triangulation, PnP-RANSAC",
    "orb-pnp": "seed 003's baseline: ORB (or SIFT) descriptor matching, stereo triangulation, PnP-RANSAC",
    "vins-ac-gf": "Seed 002 VINS-AC (g_f): visual information scaled by 1/g_f (equations 22-26), Cauchy loss",
    "vins-ac": "Seed 002 VINS-AC (g_f, N): visual information scaled by N s / g_f (equation 26), Cauchy loss",
    "vins-ac-me": "Seed 002 VINS-AC-ME: adaptive covariance (equation 26) and adaptive Huber k_t = M_s N "
                  "(equations 28-30)",
    "vins-huber": "VINS with fixed visual information and a fixed-k Huber loss (comparison row)",
    "vins-oracle": "VINS (fixed information, Cauchy) without the features on moving objects, by the true "
                   "segmentation",
}


def estimator_names() -> list:
    """Registered estimator names, sorted."""
    return sorted(ESTIMATORS)


def describe(name: str) -> str:
    """One line about registered estimator ``name``."""
    if name in DESCRIPTIONS:
        return DESCRIPTIONS[name]
    own = [c.__doc__ for c in load_class(ESTIMATORS[name]).__mro__ if c is not Estimator
           and issubclass(c, Estimator) and c.__doc__]           # not the base class's docstring
    doc = own[0].strip() if own else ""
    return " ".join(doc.split("\n\n")[0].split()).split(". ")[0].rstrip(".") or "(no description)"


def load_class(path: str) -> type:
    """``"package.module:Class"`` -> the class (must subclass Estimator)."""
    return load_plugin_class(path, Estimator, "estimator", EstimatorError)


def check_spec(spec: str) -> None:
    """Raise EstimatorError now, before any work, when ``spec`` names no estimator we could run."""
    if is_external(spec):
        ExternalCommand(spec)
    elif spec in ESTIMATORS:
        return
    elif isinstance(spec, str) and ":" in spec:
        load_class(spec)
    else:
        raise EstimatorError(f"estimator {spec!r} unknown; valid names: {', '.join(estimator_names())}; or {FORMS}")


def is_external(spec: str) -> bool:
    return isinstance(spec, str) and spec.startswith("cmd:")


def make_estimator(spec: str, rig, **options) -> Estimator:
    """Build an in-process estimator from a registered name or a class path."""
    if not isinstance(spec, str) or not spec:
        raise EstimatorError(f"estimator {spec!r}: expected {FORMS}")
    if is_external(spec):
        raise EstimatorError(f"estimator {spec!r}: external commands run on a dataset folder; use ExternalCommand")
    if spec in ESTIMATORS:
        return load_class(ESTIMATORS[spec])(rig, **with_fixed_options(spec, options))
    if ":" not in spec:
        raise EstimatorError(f"estimator {spec!r} unknown; valid names: {', '.join(estimator_names())}; or {FORMS}")
    return load_class(spec)(rig, **options)


def with_fixed_options(spec: str, options: dict) -> dict:
    """``options`` plus those that registered name ``spec`` fixes (:data:`FIXED_OPTIONS`); giving one of those
    too -> EstimatorError."""
    base, fixed = FIXED_OPTIONS.get(spec, (spec, {}))
    clash = sorted(set(fixed) & set(options))
    if clash:
        raise EstimatorError(f"estimator {spec!r} is {base!r} with {clash[0]}={fixed[clash[0]]}; to choose "
                             f"{clash[0]}, run {base!r}")
    return {**fixed, **options}


def is_oracle(spec: str, options: dict | None = None) -> bool:
    """True when in-process estimator ``spec`` with ``options`` reads ground truth (its class's ``is_oracle``)."""
    if is_external(spec):
        return False
    return bool(load_class(ESTIMATORS.get(spec, spec)).is_oracle(with_fixed_options(spec, dict(options or {}))))
