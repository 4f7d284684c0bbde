"""KITTI writer -> reader: calib baseline, times, poses of the rectified left camera, images."""
from __future__ import annotations

import numpy as np
import pytest

from sim.writers import DatasetWriters, KittiWriter
from test_dataset_synth import Synth, folder_hashes, make_rig
from vo.dataset import open_dataset
from rigs.geometry import inv_T


@pytest.fixture(scope="module")
def written(tmp_path_factory):
    s = Synth()
    out = tmp_path_factory.mktemp("kitti") / "seq"
    s.write(KittiWriter(out, s.rig, s.metadata))
    return s, out


def test_layout(written):
    s, out = written
    seq = out / "sequences" / "00"
    for rel in ("calib.txt", "times.txt", "image_0/000000.png", "image_1/000004.png"):
        assert (seq / rel).is_file(), rel
    assert (out / "poses" / "00.txt").is_file() and not (out / "INCOMPLETE").exists()
    assert [ln.split(":")[0] for ln in (seq / "calib.txt").read_text().splitlines()][:4] == ["P0", "P1", "P2", "P3"]


def test_calib_gives_back_baseline_and_rig(written):
    s, out = written
    ds = open_dataset(out)
    assert ds.kind == "kitti" and ds.images_are_rectified and len(ds) == 5
    # Ideal parallel rig: rectification is the identity and calib.txt has 13 significant digits.
    assert abs(ds.rig.baseline - 0.27) < 1e-9
    assert (ds.rig.cameras[0].width, ds.rig.cameras[0].height) == (64, 48)
    assert abs(ds.rig.camera_rate_hz - 20.0) < 1e-6
    assert np.allclose(ds.rig.cameras[0].T_b_c_array, np.eye(4))          # body = c0


def test_times_and_poses_round_trip(written):
    s, out = written
    ds = open_dataset(out / "sequences" / "00")          # opening the sequence folder works too
    assert np.array_equal(ds.frame_times_ns, s.t_frames)  # exact via times_ns.txt
    secs = np.loadtxt(out / "sequences/00/times.txt")
    # %.6e keeps 7 significant digits: relative error <= 5e-7.
    assert np.allclose(secs, (s.t_frames - s.t_frames[0]) * 1e-9, rtol=5e-7, atol=0)
    gt = ds.groundtruth
    expected = np.einsum("ij,njk->nik", inv_T(s.T_w_c0[0]), s.T_w_c0)     # R0_rect = I for this rig
    assert gt.frame == "c0" and np.array_equal(gt.t_ns, s.t_frames)
    assert np.allclose(gt.T, expected, atol=1e-8)                          # %.9e over |t| < 1 m
    assert np.allclose(ds.groundtruth_cam0().T, gt.T)
    assert [g.name for g in ds.gcps] == ["G1", "G2"]


def test_images_rectified_gray(written):
    s, out = written
    f = open_dataset(out).frame(2)
    assert f.left.shape == (48, 64) and f.left.dtype == np.uint8
    # Identity rectification with K_rect = K: the remap reproduces the input inside a 1 px border.
    assert np.abs(f.left[2:-2, 2:-2].astype(int) - s.images[2][0][2:-2, 2:-2]).max() <= 1


def test_times_without_exact_file_use_seconds(written, tmp_path):
    import shutil
    s, out = written
    copy = tmp_path / "copy"
    shutil.copytree(out, copy)
    (copy / "sequences/00/times_ns.txt").unlink()
    ds = open_dataset(copy)
    # t0 from metadata + %.6e seconds: within 5e-7 relative of 0.2 s -> < 1 us.
    assert np.abs(ds.frame_times_ns - s.t_frames).max() < 1000


def test_rotated_rig_poses_are_of_rectified_camera(tmp_path):
    from rigs.rectify import stereo_rectify
    from rigs.geometry import make_T
    s = Synth()
    s.rig = make_rig(parallel=False)
    s.write(KittiWriter(tmp_path / "k", s.rig, s.metadata))
    R0 = stereo_rectify(s.rig).R0_rect
    assert np.linalg.norm(R0 - np.eye(3)) > 1e-3                         # really rotated
    T_w_r0 = s.T_w_c0 @ make_T(R0.T, np.zeros(3))
    expected = np.einsum("ij,njk->nik", inv_T(T_w_r0[0]), T_w_r0)
    assert np.allclose(open_dataset(tmp_path / "k").groundtruth.T, expected, atol=1e-8)


def test_fanout_both_matches_single_writers(tmp_path):
    s = Synth()
    s.write(DatasetWriters(tmp_path / "both", s.rig, s.metadata, fmt="both"))
    s.write(KittiWriter(tmp_path / "konly", s.rig, s.metadata))
    assert folder_hashes(tmp_path / "both" / "kitti") == folder_hashes(tmp_path / "konly")
    assert open_dataset(tmp_path / "both" / "euroc").kind == "euroc"


def test_calib_tr_maps_body_into_rectified_cam0(tmp_path):
    # Tr = T_r0_b: with it, the written poses are T_r0(0)_r0(k) = Tr inv(T_w_b(0)) T_w_b(k) inv(Tr).
    from rigs.calib_io import parse_kitti_calib
    s = Synth()
    rig = make_rig(parallel=False)
    s.rig = rig
    s.T_w_c0 = s.T_w_c0 @ inv_T(Synth().rig.cameras[0].T_b_c_array) @ rig.cameras[0].T_b_c_array
    s.write(KittiWriter(tmp_path / "tr", rig, s.metadata))
    Tr = np.vstack([parse_kitti_calib(tmp_path / "tr/sequences/00/calib.txt")["Tr"], [0, 0, 0, 1]])
    T_w_b = s.T_w_c0 @ inv_T(rig.cameras[0].T_b_c_array)
    expected = np.einsum("ij,njk,kl->nil", Tr @ inv_T(T_w_b[0]), T_w_b, inv_T(Tr))
    poses = np.loadtxt(tmp_path / "tr/poses/00.txt").reshape(-1, 3, 4)
    assert np.allclose(poses, expected[:, :3, :4], atol=1e-9)            # calib.txt prints 13 digits
    assert open_dataset(tmp_path / "tr").rig.baseline == pytest.approx(rig.baseline, abs=1e-9)
