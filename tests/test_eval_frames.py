"""`eval --gt DATASET_DIR` evaluates the left camera (extrinsics applied); mixing frames gets a warning.

The dataset is the synthetic EuRoC recording of test_dataset_synth (40 frames, a 0.2 rad/s left turn,
IMU rotated and offset from the body), so the truth of every frame is known exactly.
"""
from __future__ import annotations

import json
import shutil

import pytest

from sim.app.cli import main
from sim.writers import EurocWriter
from test_dataset_synth import Synth
from rigs.trajectory import Trajectory
from rigs.trajfile import write_tum


@pytest.fixture(scope="module")
def synth_dataset(tmp_path_factory):
    root = tmp_path_factory.mktemp("frames")
    s = Synth(n_frames=40)
    s.write(EurocWriter(root / "ds", s.rig, s.metadata))
    # a camera estimate: the exact T_w_c0 with a known, smooth position error (1 cm per second)
    T = s.T_w_c0.copy()
    T[:, 0, 3] += 0.01 * (s.t_frames - s.t_frames[0]) * 1e-9
    write_tum(root / "cam0_est_tum.txt", Trajectory(s.t_frames, T, "w", "c0"))
    return root, s


def eval_json(capsys, gt, est):
    code = 0
    try:
        main(["eval", "--gt", str(gt), "--est", str(est), "--json"])
    except SystemExit as e:
        code = e.code
    out = capsys.readouterr()
    return code, (json.loads(out.out) if code == 0 else None), out.err


def test_dataset_folder_gives_the_same_ate_as_the_cam0_file(synth_dataset, capsys):
    root, _ = synth_dataset
    est = root / "cam0_est_tum.txt"
    _, by_file, _ = eval_json(capsys, root / "ds" / "groundtruth_tum.txt", est)
    code, by_dir, err = eval_json(capsys, root / "ds", est)
    assert code == 0 and "left camera (c0)" in err
    assert by_dir["ape"]["trans_m"]["rmse"] == pytest.approx(by_file["ape"]["trans_m"]["rmse"], abs=1e-12)
    assert by_file["ape"]["trans_m"]["max"] == pytest.approx(0.01 * 39 * 0.05, abs=1e-6)  # the error we put in
    assert by_dir["warnings"] == [] and by_dir["coverage"]["fraction"] == 1.0


def test_real_euroc_folder_uses_the_extrinsics(synth_dataset, capsys, tmp_path):
    """Without our rig.yaml/groundtruth_tum.txt the folder is read as real EuRoC: IMU truth interpolated
    at the frame times and composed with T_i_c0 from sensor.yaml (1e-9 m, the text precision)."""
    root, _ = synth_dataset
    real = tmp_path / "real"
    shutil.copytree(root / "ds", real)
    for name in ("rig.yaml", "metadata.yaml", "groundtruth_tum.txt", "gcps.csv"):
        (real / name).unlink(missing_ok=True)
    _, by_file, _ = eval_json(capsys, root / "ds" / "groundtruth_tum.txt", root / "cam0_est_tum.txt")
    code, by_dir, _ = eval_json(capsys, real, root / "cam0_est_tum.txt")
    assert code == 0
    assert by_dir["ape"]["trans_m"]["rmse"] == pytest.approx(by_file["ape"]["trans_m"]["rmse"], abs=1e-6)
    assert by_dir["ape"]["rot_deg"]["rmse"] < 1e-4


def test_imu_truth_against_camera_estimate_warns(synth_dataset, capsys):
    root, s = synth_dataset
    gt_imu = root / "ds" / "mav0" / "state_groundtruth_estimate0" / "data.csv"
    code, res, err = eval_json(capsys, gt_imu, root / "cam0_est_tum.txt")
    assert code == 0
    assert res["ape"]["rot_deg"]["rmse"] > 5
    assert len(res["warnings"]) == 1 and "different frames" in res["warnings"][0]
    assert "--gt" in res["warnings"][0] and "warning:" in err
    assert "same angles as the truth" in res["warnings"][0]      # conjugated rotations: the cause is sure
