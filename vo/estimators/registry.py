"""Estimator registry: names -> lazily imported classes, user plug-in class paths, external commands.

Accepted specs: a registered name (:data:`ESTIMATORS`), ``"package.module:Class"`` (a subclass of
:class:`vo.estimators.base.Estimator`), or ``"cmd:<template>"`` for an external program (see
:class:`ExternalCommand`).
"""
from __future__ import annotations

import importlib
import shlex
import subprocess
from pathlib import Path

from vo.errors import EstimatorError
from vo.estimators.base import Estimator

ESTIMATORS = {
    "rop": "vo.rop.estimator:RopEstimator",
    "klt-pnp": "vo.estimators.pnp:KltPnpEstimator",
    "orb-pnp": "vo.estimators.pnp:OrbPnpEstimator",
}
FORMS = "a registered name, 'package.module:Class', or 'cmd:<command with {dataset} and {out}>'"


def estimator_names() -> list:
    """Registered estimator names, sorted."""
    return sorted(ESTIMATORS)


def load_class(path: str) -> type:
    """``"package.module:Class"`` -> the class (must subclass Estimator)."""
    module, _, attr = path.partition(":")
    if not module or not attr:
        raise EstimatorError(f"estimator {path!r}: expected 'package.module:Class'")
    try:
        cls = getattr(importlib.import_module(module), attr)
    except ImportError as e:
        raise EstimatorError(f"estimator {path!r}: cannot import module {module!r} ({e})") from None
    except AttributeError:
        raise EstimatorError(f"estimator {path!r}: module {module!r} has no attribute {attr!r}") from None
    if not (isinstance(cls, type) and issubclass(cls, Estimator)):
        raise EstimatorError(f"estimator {path!r}: not a subclass of vo.estimators.base.Estimator")
    return cls


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
        """Run once; returns ``out_path``. Failure -> EstimatorError with exit code and last stderr line."""
        cmd = self.command(dataset_path, out_path)
        try:
            proc = subprocess.run(cmd, shell=self.shell, capture_output=True, text=True, timeout=self.timeout_s)
        except FileNotFoundError as e:
            raise EstimatorError(f"external command {self.cmd_template!r}: program not found ({e.filename})") from None
        except subprocess.TimeoutExpired:
            raise EstimatorError(f"external command {self.cmd_template!r}: timed out after {self.timeout_s} s") from None
        if proc.returncode != 0:
            last = next((l for l in reversed(proc.stderr.splitlines()) if l.strip()), "")
            raise EstimatorError(f"external command {self.cmd_template!r} failed with exit code "
                                 f"{proc.returncode}: {last}")
        if not Path(out_path).is_file():
            raise EstimatorError(f"external command {self.cmd_template!r}: exit 0 but wrote no trajectory to {out_path}")
        return Path(out_path)
