"""Estimator registry: names -> lazily imported classes, user plug-in class paths, external commands.

Accepted specs: a registered name (:data:`ESTIMATORS`), ``"package.module:Class"`` (a subclass of
:class:`vo.estimators.base.Estimator`), or ``"cmd:<template>"`` for an external program (see
:class:`ExternalCommand`).
"""
from __future__ import annotations

import shlex
import subprocess
from pathlib import Path

from rigs.plugins import load_plugin_class
from vo.errors import EstimatorError
from vo.estimators.base import Estimator

ESTIMATORS = {
    "rop": "vo.rop.estimator:RopEstimator",
    "klt-pnp": "vo.estimators.pnp:KltPnpEstimator",
    "orb-pnp": "vo.estimators.pnp:OrbPnpEstimator",
    "vins": "vo.vins.estimator:VinsEstimator",
    "vins-ac-gf": "vo.vins.estimator:VinsAcGf",
    "vins-ac": "vo.vins.estimator:VinsAc",
    "vins-ac-me": "vo.vins.estimator:VinsAcMe",
    "vins-huber": "vo.vins.estimator:VinsHuber",
    "vins-oracle": "vo.vins.estimator:VinsOracle",
}
FORMS = "a registered name, 'package.module:Class', or 'cmd:<command with {dataset} and {out}>'"
# one line each for `vo-testbed list`; a name without one shows its class docstring's first sentence
DESCRIPTIONS = {
    "rop": "seed 000: stereo VO by relative-orientation-parameter (ROP) adjustment, with propagated covariance",
    "klt-pnp": "seed 003: KLT optical-flow tracking on a feature grid, stereo triangulation, PnP-RANSAC",
    "orb-pnp": "seed 003's baseline: ORB (or SIFT) descriptor matching, stereo triangulation, PnP-RANSAC",
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


class ExternalCommandError(EstimatorError):
    """An external program failed; ``stderr`` holds what it printed there."""

    def __init__(self, message: str, stderr: str = ""):
        super().__init__(message)
        self.stderr = stderr


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
        return load_class(ESTIMATORS[spec])(rig, **options)
    if ":" not in spec:
        raise EstimatorError(f"estimator {spec!r} unknown; valid names: {', '.join(estimator_names())}; or {FORMS}")
    return load_class(spec)(rig, **options)


class ExternalCommand:
    """An external VO program: ``cmd_template`` holds ``{dataset}`` and ``{out}``, e.g.
    ``"my_vo --data {dataset} --traj {out}"``; the program must write a TUM trajectory of ``T_o_c0`` to ``{out}``.

    Run without a shell (``shlex.split``) unless ``shell=True``.
    """

    def __init__(self, cmd_template: str, shell: bool = False, timeout_s: float | None = None):
        if cmd_template.startswith("cmd:"):
            cmd_template = cmd_template[4:]
        for key in ("{dataset}", "{out}"):
            if key not in cmd_template:
                raise EstimatorError(f"external command {cmd_template!r}: template must contain {key} (and "
                                     "{dataset}, {out})")
        self.cmd_template, self.shell, self.timeout_s = cmd_template.strip(), shell, timeout_s
        self.name = "cmd:" + (shlex.split(self.cmd_template) or ["?"])[0]

    def command(self, dataset_path, out_path):
        """The argument list (or shell string) for one run."""
        if self.shell:
            return self.cmd_template.format(dataset=shlex.quote(str(dataset_path)), out=shlex.quote(str(out_path)))
        return [a.format(dataset=str(dataset_path), out=str(out_path)) for a in shlex.split(self.cmd_template)]

    def run(self, dataset_path, out_path) -> Path:
        """Run once; returns ``out_path`` (what the program wrote to stderr is kept in ``self.stderr``).
        Failure -> ExternalCommandError with exit code and last stderr line (all of it in ``.stderr``)."""
        cmd = self.command(dataset_path, out_path)
        self.stderr = ""
        try:
            proc = subprocess.run(cmd, shell=self.shell, capture_output=True, text=True, timeout=self.timeout_s)
        except FileNotFoundError as e:
            raise EstimatorError(f"external command {self.cmd_template!r}: program not found ({e.filename})") from None
        except subprocess.TimeoutExpired:
            raise EstimatorError(f"external command {self.cmd_template!r}: timed out after {self.timeout_s} s") from None
        self.stderr = proc.stderr
        if proc.returncode != 0:
            last = next((l for l in reversed(proc.stderr.splitlines()) if l.strip()), "")
            raise ExternalCommandError(f"external command {self.cmd_template!r} failed with exit code "
                                       f"{proc.returncode}: {last}", proc.stderr)
        if not Path(out_path).is_file():
            raise ExternalCommandError(f"external command {self.cmd_template!r}: exit 0 but wrote no trajectory "
                                       f"to {{out}}", proc.stderr)
        return Path(out_path)
