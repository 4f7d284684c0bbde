"""The VINS study drivers (docs/studies/vins_tables.py, vins_postinit_nees.py, vins_start_table.py,
vins_initial_report.py, vins_start_window.py) on bad input: one ``error:`` line, exit 2."""
import numpy as np
import pytest
from studies import load_study

tables = load_study("vins_tables")
postinit_nees = load_study("vins_postinit_nees")
start_table = load_study("vins_start_table")
initial_report = load_study("vins_initial_report")
start_window = load_study("vins_start_window")


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


def test_start_table_and_initial_report_missing_dataset(tmp_path, capsys):
    assert start_table.main([str(tmp_path / "none")]) == 2
    assert "dataset folder not found" in _one_error_line(capsys)
    assert initial_report.main([str(tmp_path / "none")]) == 2
    assert "dataset folder not found" in _one_error_line(capsys)
    assert initial_report.main([str(tmp_path), "10", "landmark"]) == 2
    assert "usage" in capsys.readouterr().err


def test_start_window_missing_dataset_or_bad_option(tmp_path, capsys):
    assert start_window.main([str(tmp_path / "none")]) == 2
    assert "dataset folder not found" in _one_error_line(capsys)
    assert start_window.main([str(tmp_path), "10", "landmark"]) == 2
    assert _one_error_line(capsys).startswith("error:")
    assert start_window.main([]) == 2
    assert "usage" in capsys.readouterr().err
