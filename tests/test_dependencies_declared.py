"""Every third-party package the product code imports (sim/, rigs/, scenes/, vo/, at any level, lazy
imports included) is declared in pyproject.toml, as a dependency or in an extra, with a version range."""
import ast
import re
import sys
import tomllib
from importlib.metadata import packages_distributions
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
OWN = {"sim", "rigs", "scenes", "vo"}


def imported_top_modules() -> dict:
    """{top-level module name: first file importing it} over the product packages."""
    found = {}
    for pkg in sorted(OWN):
        for path in sorted((ROOT / pkg).rglob("*.py")):
            for node in ast.walk(ast.parse(path.read_text(), str(path))):
                names = [a.name for a in node.names] if isinstance(node, ast.Import) else \
                    [node.module] if isinstance(node, ast.ImportFrom) and node.module and node.level == 0 else []
                for n in names:
                    found.setdefault(n.split(".")[0], str(path.relative_to(ROOT)))
    return found


def declared() -> dict:
    """{normalised distribution name: requirement string} from [project] dependencies and every extra."""
    proj = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    reqs = list(proj["dependencies"]) + [r for extra in proj["optional-dependencies"].values() for r in extra]
    return {re.split(r"[\[<>=!~ ;]", r, maxsplit=1)[0].lower().replace("_", "-"): r for r in reqs}


def test_every_third_party_import_is_declared_with_a_range():
    dists = packages_distributions()
    have = declared()
    missing = []
    for mod, where in imported_top_modules().items():
        if mod in OWN or mod in sys.stdlib_module_names or mod == "__future__":
            continue
        names = [d.lower().replace("_", "-") for d in dists.get(mod, [mod])]   # not installed: module name
        hit = [n for n in names if n in have]
        if not hit:
            missing.append(f"{mod} (imported by {where})")
        else:
            assert re.search(r"[<>=~]", have[hit[0]]), f"{have[hit[0]]}: no version range"
    assert not missing, missing


def test_sweep_extra_declares_psutil_and_pyarrow():
    extra = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["optional-dependencies"]["sweep"]
    assert any(r.startswith("psutil>=") for r in extra) and any(r.startswith("pyarrow>=") for r in extra)
