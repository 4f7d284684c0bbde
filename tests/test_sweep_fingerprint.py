"""The code fingerprint of sweep records: what it covers, that any source byte changes it, and which
records count as stale. (The resume behaviour on real cells is in tests/test_sweep_run.py.)"""
import hashlib

import pytest

from sim.app.sweep import fingerprint
from sim.app.sweep.cell import is_done, is_stale
from sim.app.sweep.fingerprint import code_fingerprint, fingerprint_files, source_files
from sim.app.sweep.table import read_csv, tidy_rows, to_csv


@pytest.fixture
def tmp_package(tmp_path, monkeypatch):
    """A package ``fp_pkg`` (core modules, an app folder left out except one file, a data file) that the
    fingerprint covers instead of ours; the per-process cache is cleared before and after."""
    root = tmp_path / "fp_pkg"
    for rel, text in {"__init__.py": "", "core.py": "X = 1\n", "sub/__init__.py": "", "sub/model.py": "Y = 2\n",
                      "app/__init__.py": "", "app/plots.py": "P = 3\n", "app/cell.py": "C = 4\n",
                      "data.yaml": "a: 1\n"}.items():
        (root / rel).parent.mkdir(parents=True, exist_ok=True)
        (root / rel).write_text(text)
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.setattr(fingerprint, "PACKAGES", ("fp_pkg",))
    monkeypatch.setattr(fingerprint, "EXCLUDED", ("fp_pkg/app",))
    monkeypatch.setattr(fingerprint, "INCLUDED", ("fp_pkg/app/cell.py",))
    code_fingerprint.cache_clear()
    yield root
    code_fingerprint.cache_clear()


def _fresh():
    code_fingerprint.cache_clear()
    return code_fingerprint()


def test_fingerprint_covers_the_sources_and_is_stable(tmp_package):
    assert [rel for rel, _ in source_files()] == ["fp_pkg/__init__.py", "fp_pkg/app/cell.py", "fp_pkg/core.py",
                                                  "fp_pkg/sub/__init__.py", "fp_pkg/sub/model.py"]
    first = code_fingerprint()
    assert len(first) == 16 and int(first, 16) >= 0
    assert code_fingerprint() == first == _fresh()
    # the digest is sha256 over (path, length, bytes) of those files in that order, independent of where
    expected = hashlib.sha256()
    for rel, path in source_files():
        data = path.read_bytes()
        expected.update(rel.encode() + b"\0" + str(len(data)).encode() + b"\0" + data)
    assert first == expected.hexdigest()[:16]


def test_any_source_byte_changes_the_fingerprint(tmp_package):
    f0 = code_fingerprint()
    (tmp_package / "sub" / "model.py").write_text("Y = 3\n")          # one byte
    assert code_fingerprint() == f0                                     # cached for the process
    f1 = _fresh()
    assert f1 != f0
    (tmp_package / "app" / "cell.py").write_text("C = 5\n")           # the one app file that runs the cell
    f2 = _fresh()
    assert f2 != f1
    (tmp_package / "app" / "plots.py").write_text("P = 4\n")          # reporting: does not change numbers
    (tmp_package / "data.yaml").write_text("a: 2\n")                   # not a source file
    assert _fresh() == f2
    (tmp_package / "sub" / "model.py").rename(tmp_package / "sub" / "model2.py")   # same bytes, new path
    assert _fresh() != f2


def test_our_fingerprint_leaves_out_the_app_layer_but_its_cell_runner():
    rels = [rel for rel, _ in source_files()]
    assert "sim/app/sweep/cell.py" in rels
    assert not [r for r in rels if r.startswith("sim/app/") and r != "sim/app/sweep/cell.py"]
    for pkg in ("rigs", "scenes", "sim", "vo"):
        assert f"{pkg}/__init__.py" in rels
    assert "vo/estimators/registry.py" in rels and "sim/generate.py" in rels
    assert code_fingerprint() == fingerprint_files(source_files())


def test_stale_records_are_not_done_unless_kept():
    current = {"code": "aaaaaaaaaaaaaaaa", "error": None, "runs": {"rop": {"error": None}}}
    other = dict(current, code="bbbbbbbbbbbbbbbb")
    unmarked = {k: v for k, v in current.items() if k != "code"}
    failed = dict(other, error="SimError: bad scene", runs={})
    assert not is_stale(current, "aaaaaaaaaaaaaaaa")
    assert is_stale(other, "aaaaaaaaaaaaaaaa") and is_stale(unmarked, "aaaaaaaaaaaaaaaa")
    assert is_done(current, ("rop",), code="aaaaaaaaaaaaaaaa")
    for rec in (other, unmarked, failed):                 # made by other code: runs again ...
        assert not is_done(rec, ("rop",), code="aaaaaaaaaaaaaaaa")
        assert is_done(rec, ("rop",))                     # ... unless the code is not checked (--keep-stale)


def test_tidy_table_carries_the_code_column(tmp_path):
    records = [{"key": "k1", "code": "0123456789012345", "seed": 0, "values": {"baseline": 0.12}, "error": None,
                "runs": {"rop": {"error": None, "drift_pct": 0.5}}},
               {"key": "k2", "seed": 0, "values": {"baseline": 0.27}, "error": None,
                "runs": {"rop": {"error": None, "drift_pct": 0.3}}}]
    rows = tidy_rows(records, ["baseline"], ("rop",))
    assert [r["code"] for r in rows] == ["0123456789012345", ""]
    (tmp_path / "results.csv").write_text(to_csv(rows))
    back = read_csv(tmp_path / "results.csv")
    assert [r["code"] for r in back] == ["0123456789012345", ""]       # an all-digit digest stays text


def test_mixed_code_warning_names_each_count():
    from sim.app.sweep.driver import mixed_code_warning
    assert mixed_code_warning({"aaaaaaaaaaaaaaaa": 4}, "aaaaaaaaaaaaaaaa") == ""
    line = mixed_code_warning({"aaaaaaaaaaaaaaaa": 1, "bbbbbbbbbbbbbbbb": 3, "": 2}, "aaaaaaaaaaaaaaaa")
    assert "\n" not in line and line.startswith("warning: the records come from 3 code versions")
    assert "bbbbbbbbbbbbbbbb: 3 cells, no fingerprint: 2 cells, aaaaaaaaaaaaaaaa (current): 1 cells" in line
