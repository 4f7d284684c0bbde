"""Every product module imports alone, in a fresh interpreter: no import circle that only an import order hides.

tests/test_import_cycles.py checks the import graph (module level and inside functions) on every run; this test
is the direct check, one interpreter per module (about 260 of them, two at a time: minutes, hence ``long``)."""
import os
import pkgutil
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("rigs", "scenes", "sim", "vo")


def product_modules() -> list:
    """Dotted names of every module of the product packages (packages included)."""
    names = []
    for pkg in PACKAGES:
        names.append(pkg)
        for info in pkgutil.walk_packages([str(ROOT / pkg)], pkg + "."):
            names.append(info.name)
    return sorted(names)


def import_alone(name: str) -> tuple:
    env = dict(os.environ, PYTHONPATH=str(ROOT), MUJOCO_GL=os.environ.get("MUJOCO_GL", "egl"))
    r = subprocess.run([sys.executable, "-c", f"import {name}"], env=env, cwd=ROOT, capture_output=True,
                       text=True, timeout=300)
    return name, r.returncode, r.stderr.strip().splitlines()[-1:] if r.returncode else []


def test_the_module_list_is_the_product():
    mods = product_modules()
    assert len(mods) > 200 and "sim.generate" in mods and "vo.vins.estimator" in mods
    assert not any(m.startswith("tests") for m in mods)
    name, rc, err = import_alone("vo._no_such_module")        # the check can fail
    assert rc != 0 and "ModuleNotFoundError" in err[0]


@pytest.mark.long
def test_every_product_module_imports_alone():
    with ThreadPoolExecutor(2) as pool:
        failed = [(n, err) for n, rc, err in pool.map(import_alone, product_modules()) if rc]
    assert failed == []
