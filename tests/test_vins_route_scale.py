"""The whole-route scale study (docs/studies/vins_route_scale.py) against exact synthetic trajectories, and the
bad input of it and of docs/studies/vins_dynamic_window.py: one ``error:`` line, exit 2."""
import numpy as np
import pytest
from studies import load_study

route_scale = load_study("vins_route_scale")
dynamic_window = load_study("vins_dynamic_window")


def _straight(n=201, speed=10.0, rate=10.0):
    """Camera poses driving along w x at ``speed`` (camera z = x: direction of travel), t_ns at ``rate`` Hz."""
    t_ns = np.arange(n, dtype=np.int64) * int(1e9 / rate)
    T = np.tile(np.eye(4), (n, 1, 1))
    T[:, :3, :3] = [[0, 0, 1], [-1, 0, 0], [0, -1, 0]]
    T[:, 0, 3] = speed * t_ns * 1e-9
    return t_ns, T


def test_a_scaled_route_gives_its_scale_error_and_along_track_error():
    t_ns, T_gt = _straight()
    T_est = T_gt.copy()
    T_est[:, :3, 3] = T_gt[:, :3, 3] * 1.10 + [5.0, -3.0, 2.0]     # 10 % too long, another origin
    status = ["init"] * 20 + ["ok"] * 181
    rows = route_scale.segments(t_ns, T_gt, T_est, status, 5.0)
    assert len(rows) == 4                       # 18 s of covered frames in 5-s segments
    for t0, t1, speed, scale_pct, along, err in rows:
        assert speed == pytest.approx(10.0)
        assert scale_pct == pytest.approx(10.0, abs=1e-9)
        d = 10.0 * (t1 - 2.0)                   # true distance from the first covered frame (t = 2 s)
        assert along == pytest.approx(0.1 * d, abs=1e-9) and err == pytest.approx(0.1 * d, abs=1e-9)
    assert "+10.0 .. +10.0 %" in route_scale.summary(rows) and "(+10.0 % of 180 m)" in route_scale.summary(rows)


def test_frames_without_a_pose_are_left_out():
    t_ns, T_gt = _straight(51)
    status = ["ok"] * 20 + ["reinit"] * 31
    T_est = T_gt.copy()
    T_est[20:] = T_est[19]                      # the held pose of reinit frames
    rows = route_scale.segments(t_ns, T_gt, T_est, status, 10.0)
    assert rows[-1][1] == pytest.approx(1.9) and rows[-1][5] == pytest.approx(0.0, abs=1e-9)
    assert route_scale.segments(t_ns, T_gt, T_est, ["init"] * 51, 10.0) == []


def _one_error_line(capsys) -> str:
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "Traceback" not in err
    return err


def test_route_scale_bad_input(tmp_path, capsys):
    assert route_scale.main([str(tmp_path / "none"), str(tmp_path / "t.npz")]) == 2
    assert "dataset folder not found" in _one_error_line(capsys)
    assert route_scale.main([str(tmp_path / "none")]) == 2
    assert "pairs" in _one_error_line(capsys)


def test_dynamic_window_missing_dataset(tmp_path, capsys):
    assert dynamic_window.main([str(tmp_path / "none")]) == 2
    assert _one_error_line(capsys).startswith("error:")
