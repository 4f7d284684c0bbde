"""The command line (``vo-testbed``, ``[project.scripts]``) is the one entry point: no module of the product
packages runs as ``python -m`` (no ``__main__`` module, no ``if __name__ == "__main__"`` block)."""
import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("rigs", "scenes", "sim", "vo")


def _runs_as_main(tree: ast.Module) -> bool:
    for node in tree.body:
        if isinstance(node, ast.If) and isinstance(node.test, ast.Compare):
            names = {getattr(n, "id", None) for n in (node.test.left, *node.test.comparators)}
            consts = {getattr(n, "value", None) for n in (node.test.left, *node.test.comparators)}
            if "__name__" in names and "__main__" in consts:
                return True
    return False


def entry_points(root: Path) -> list:
    """Paths (relative to ``root``) of product modules that run as ``python -m``."""
    out = []
    for pkg in PACKAGES:
        for path in sorted((root / pkg).rglob("*.py")):
            rel = path.relative_to(root).as_posix()
            if path.name == "__main__.py" or _runs_as_main(ast.parse(path.read_text(), rel)):
                out.append(rel)
    return out


def test_the_check_finds_a_main_block(tmp_path):
    (tmp_path / "sim").mkdir()
    (tmp_path / "sim" / "tool.py").write_text("def main():\n    pass\n\n\nif __name__ == '__main__':\n    main()\n")
    (tmp_path / "sim" / "quiet.py").write_text("NAME = '__main__'\n")
    (tmp_path / "vo").mkdir()
    (tmp_path / "vo" / "__main__.py").write_text("")
    assert entry_points(tmp_path) == ["sim/tool.py", "vo/__main__.py"]


def test_no_python_m_entry_points_in_the_product():
    assert entry_points(ROOT) == []

