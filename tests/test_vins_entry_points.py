"""``python -m vo.vins.tables`` / ``vo.vins.postinit_nees`` on bad input: one ``error:`` line, exit 2."""
import numpy as np
import pytest

from vo.vins import postinit_nees, tables


def _one_error_line(capsys) -> str:
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "Traceback" not in err
    return err


def test_tables_missing_dataset(tmp_path, capsys):
    assert tables.main([str(tmp_path / "none"), str(tmp_path / "out"), "10", "vins"]) == 2
    assert "dataset folder not found" in _one_error_line(capsys)


def test_tables_bad_arguments(tmp_path, capsys):
    with pytest.raises(SystemExit) as e:
        tables.main([str(tmp_path), str(tmp_path / "out"), "ten", "vins"])
    assert e.value.code == 2
    with pytest.raises(SystemExit) as e:
        tables.main([str(tmp_path), str(tmp_path / "out"), "10", "vins", "landmark"])
    assert e.value.code == 2 and "key=value" in capsys.readouterr().err


def test_postinit_nees_missing_or_malformed_file(tmp_path, capsys):
    assert postinit_nees.main([str(tmp_path / "runs.npz")]) == 2
    assert "runs.npz" in _one_error_line(capsys)
    bad = tmp_path / "bad.npz"
    np.savez(bad, T_est=np.zeros((2, 3, 4, 4)))
    assert postinit_nees.main([str(bad)]) == 2
    assert "'cov'" in _one_error_line(capsys)
