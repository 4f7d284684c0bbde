"""No import circle among our modules, and every module imports on its own.

The import graph (grimp, installed with import-linter) holds every ``import`` statement of rigs, scenes,
sim and vo, module level and inside functions; a strongly connected component of more than one module
is a circle. The second test imports each module first thing after our packages are dropped from
``sys.modules`` (one interpreter for all, so it stays fast), which fails for a module that only
imports when something else was imported before it.
"""
import os
import subprocess
import sys
import textwrap
from collections import defaultdict
from pathlib import Path

import numpy as np
import pytest
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import connected_components

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("rigs", "scenes", "sim", "vo")


def _graph():
    grimp = pytest.importorskip("grimp")
    return grimp.build_graph(*PACKAGES, cache_dir=None)


def import_circles(graph) -> list:
    """Sets of modules that import each other in a circle (strongly connected components of size > 1)."""
    mods = sorted(graph.modules)
    ix = {m: i for i, m in enumerate(mods)}
    edges = [(ix[m], ix[d]) for m in mods for d in graph.find_modules_directly_imported_by(m)]
    rows, cols = zip(*edges)
    adj = csr_matrix((np.ones(len(edges)), (rows, cols)), shape=(len(mods), len(mods)))
    _, labels = connected_components(adj, directed=True, connection="strong")
    comps = defaultdict(set)
    for m, lab in zip(mods, labels):
        comps[lab].add(m)
    return sorted((frozenset(c) for c in comps.values() if len(c) > 1), key=sorted)


def test_the_circle_finder_sees_a_function_level_circle(tmp_path):
    """A planted pair, one of its imports inside a function, is found (the check can fail)."""
    pkg = tmp_path / "circpkg"
    pkg.mkdir()
    (pkg / "__init__.py").write_text("")
    (pkg / "a.py").write_text("import circpkg.b\n")
    (pkg / "b.py").write_text("def f():\n    import circpkg.a\n")
    (pkg / "c.py").write_text("import circpkg.a\n")
    grimp = pytest.importorskip("grimp")
    sys.path.insert(0, str(tmp_path))
    try:
        graph = grimp.build_graph("circpkg", cache_dir=None)
    finally:
        sys.path.remove(str(tmp_path))
    assert import_circles(graph) == [frozenset({"circpkg.a", "circpkg.b"})]


def test_no_import_circle():
    circles = import_circles(_graph())
    assert circles == [], "import circles: " + "; ".join(" <-> ".join(sorted(c)) for c in circles)


def test_no_vins_circle():
    """The VINS estimator, its initialisations (``initial``, ``truth_init``) and the study helpers they once
    reached back through (start-up recorder, tables) import one way: no circle holds a ``vo.vins`` module."""
    circles = [c for c in import_circles(_graph()) if any(m.startswith("vo.vins") for m in c)]
    assert circles == [], "import circles: " + "; ".join(" <-> ".join(sorted(c)) for c in circles)


_IMPORT_EACH = textwrap.dedent("""
    import importlib, sys, traceback
    ours = {packages!r}
    failed = []
    for name in sys.argv[1:]:
        for m in [m for m in sys.modules if m.split(".")[0] in ours]:
            del sys.modules[m]
        try:
            importlib.import_module(name)
        except Exception as e:
            failed.append(f"{{name}}: {{type(e).__name__}}: {{e}}")
    print("\\n".join(failed))
    sys.exit(1 if failed else 0)
""")


def test_the_import_check_fails_for_a_module_that_needs_another_first(tmp_path):
    """``a`` imports only after ``b`` (its circle is order-dependent); listed after ``b``, it still fails."""
    pkg = tmp_path / "circ"
    pkg.mkdir()
    (pkg / "__init__.py").write_text("")
    (pkg / "a.py").write_text("import circ.b\nY = 1\n")
    (pkg / "b.py").write_text("from circ.a import Y\n")
    res = subprocess.run([sys.executable, "-c", _IMPORT_EACH.format(packages=("circ",)), "circ.b", "circ.a"],
                         cwd=tmp_path, env={"PYTHONPATH": str(tmp_path), "PATH": "/usr/bin:/bin"},
                         capture_output=True, text=True, timeout=60)
    assert res.returncode == 1
    assert res.stdout.strip().splitlines() == ["circ.a: ImportError: cannot import name 'Y' from partially "
                                               "initialized module 'circ.a' (most likely due to a circular "
                                               f"import) ({pkg / 'a.py'})"]


@pytest.mark.slow
def test_every_module_imports_alone():
    """Each module of rigs, scenes, sim and vo imports first thing in an interpreter holding none of ours."""
    names = sorted(m for m in _graph().modules if not m.endswith("__main__"))
    assert len(names) > 150
    code = _IMPORT_EACH.format(packages=PACKAGES)
    env = {"PYTHONPATH": str(ROOT), "PATH": "/usr/bin:/bin", "MUJOCO_GL": "egl", "MPLBACKEND": "Agg",
           "HOME": os.environ.get("HOME", "/tmp")}
    res = subprocess.run([sys.executable, "-c", code, *names], cwd=ROOT, env=env, capture_output=True, text=True,
                         timeout=300)
    assert res.returncode == 0, res.stdout[-4000:] + res.stderr[-2000:]
