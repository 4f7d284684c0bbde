"""The layer contracts of docs/ARCHITECTURE.md (``[tool.importlinter]`` in pyproject.toml) hold, and
the check fails when one is broken (a violation planted in a copy of the tree)."""
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("rigs", "scenes", "sim", "vo")


def _lint(cwd: Path, pythonpath: Path) -> subprocess.CompletedProcess:
    lint = Path(sys.executable).with_name("lint-imports")
    if not lint.exists():
        pytest.skip("import-linter is not installed (pip install -e '.[test]')")
    env = {"PYTHONPATH": str(pythonpath), "PATH": "/usr/bin:/bin"}
    return subprocess.run([str(lint), "--config", str(cwd / "pyproject.toml"), "--no-cache"], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=300)


def test_layer_contracts_hold():
    res = _lint(ROOT, ROOT)
    assert res.returncode == 0, res.stdout[-3000:] + res.stderr[-2000:]
    assert "0 broken" in res.stdout


@pytest.mark.parametrize("planted, contract", [
    ("vo/_planted.py", "vo imports neither sim, scenes nor mujoco"),
    ("rigs/geometry/_planted.py", "rigs.geometry imports nothing of ours"),
    ("sim/_planted.py", "only the app layer imports the app layer"),
    ("sim/sensors/_planted.py", "sim imports nothing from vo (the app layer sim.app may import both)"),
])
def test_a_planted_violation_breaks_its_contract(tmp_path, planted, contract):
    for pkg in PACKAGES:
        shutil.copytree(ROOT / pkg, tmp_path / pkg, ignore=shutil.ignore_patterns("__pycache__"))
    shutil.copy(ROOT / "pyproject.toml", tmp_path / "pyproject.toml")
    target = {"vo/_planted.py": "import sim.generate\n", "rigs/geometry/_planted.py": "import rigs.model\n",
              "sim/_planted.py": "import sim.app.check\n", "sim/sensors/_planted.py": "import vo.eval.metrics\n"}[planted]
    (tmp_path / planted).write_text(target)
    res = _lint(tmp_path, tmp_path)
    assert res.returncode != 0
    assert f"{contract} BROKEN" in res.stdout
    assert "1 broken" in res.stdout
