"""Small modules with one job: every ``.py`` of the product packages (sim, rigs, scenes, vo) has at most
:data:`MAX_LINES` lines. The checker itself is tested on planted files (400 lines pass, 401 fail), so the
tree-wide check cannot pass by finding nothing."""
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("sim", "rigs", "scenes", "vo")
MAX_LINES = 400


def line_count(path: Path) -> int:
    """Lines of ``path`` as an editor numbers them (a last line without a newline counts)."""
    return len(path.read_text(encoding="utf-8").splitlines())


def oversized(root: Path, packages=PACKAGES, max_lines: int = MAX_LINES) -> list:
    """``(relative path, lines)`` of every ``.py`` under ``root/<package>`` longer than ``max_lines``."""
    out = []
    for pkg in packages:
        for p in sorted((root / pkg).rglob("*.py")):
            if "__pycache__" in p.parts:
                continue
            n = line_count(p)
            if n > max_lines:
                out.append((p.relative_to(root).as_posix(), n))
    return out


def test_every_product_module_is_at_most_400_lines():
    n_files = sum(1 for pkg in PACKAGES for _ in (ROOT / pkg).rglob("*.py"))
    assert n_files > 100, f"only {n_files} modules found under {PACKAGES}: wrong root?"
    assert oversized(ROOT) == [], f"modules over {MAX_LINES} lines (split them by job)"


def test_the_checker_finds_a_planted_401_line_module(tmp_path):
    pkg = tmp_path / "vo" / "sub"
    pkg.mkdir(parents=True)
    (pkg / "ok.py").write_text("x = 1\n" * MAX_LINES)
    (pkg / "big.py").write_text("x = 1\n" * MAX_LINES + "y = 2")      # 401 lines, the last one unterminated
    (tmp_path / "docs").mkdir()
    (tmp_path / "docs" / "study.py").write_text("x = 1\n" * 1000)      # outside the product packages
    assert line_count(pkg / "ok.py") == MAX_LINES
    assert oversized(tmp_path) == [("vo/sub/big.py", MAX_LINES + 1)]
    (pkg / "big.py").write_text("x = 1\n" * MAX_LINES)
    assert oversized(tmp_path) == []
