"""Reader refusals: incomplete, missing, truncated, NaN, malformed; writer refusals; no mujoco in vo."""
from __future__ import annotations

import subprocess
import sys

import pytest

from sim.writers import EurocWriter, KittiWriter
from sim.errors import SimError
from test_dataset_synth import Synth
from vo.dataset import open_dataset
from vo.errors import DatasetError


def one_line_error(path, match):
    with pytest.raises(DatasetError, match=match) as info:
        open_dataset(path).imu          # touch a lazy loader too
    msg = str(info.value)
    assert "\n" not in msg
    return msg


@pytest.fixture
def euroc(tmp_path):
    s = Synth(n_frames=3)
    s.write(EurocWriter(tmp_path / "ds", s.rig, s.metadata))
    return tmp_path / "ds"


def test_incomplete_folder_is_refused(tmp_path):
    s = Synth(n_frames=2)
    s.write(EurocWriter(tmp_path / "ds", s.rig, s.metadata), finalize=False)
    msg = one_line_error(tmp_path / "ds", "incomplete")
    assert str(tmp_path / "ds") in msg and "resume" in msg
    s.write(KittiWriter(tmp_path / "k", s.rig, s.metadata), finalize=False)
    assert str(tmp_path / "k") in one_line_error(tmp_path / "k" / "sequences" / "00", "incomplete")


def test_missing_folder(tmp_path):
    msg = one_line_error(tmp_path / "nope", "not found")
    assert str(tmp_path / "nope") in msg


def test_unrecognised_folder(tmp_path):
    (tmp_path / "x.txt").write_text("hi")
    one_line_error(tmp_path, "not a recognised dataset")


def test_truncated_imu_csv_names_file_and_line(euroc):
    p = euroc / "mav0/imu0/data.csv"
    p.write_text(p.read_text()[:-25])           # cut the last line in the middle
    msg = one_line_error(euroc, "imu0/data.csv: line 31: expected 7 comma-separated values")
    assert "\n" not in msg


def test_nan_in_groundtruth_names_file_and_line(euroc):
    p = euroc / "mav0/state_groundtruth_estimate0/data.csv"
    lines = p.read_text().splitlines()
    parts = lines[5].split(",")
    parts[2] = "nan"
    lines[5] = ",".join(parts)
    p.write_text("\n".join(lines) + "\n")
    with pytest.raises(DatasetError, match=r"state_groundtruth_estimate0/data.csv: line 6: p_y is NaN"):
        open_dataset(euroc).groundtruth


def test_missing_camera_csv_and_image(euroc):
    (euroc / "mav0/cam1/data.csv").unlink()
    one_line_error(euroc, r"cam1/data.csv: camera list file not found")


def test_missing_image_file_on_frame_access(euroc):
    ds = open_dataset(euroc)
    png = euroc / f"mav0/cam0/data/{ds.frame_times_ns[1]}.png"
    png.unlink()
    with pytest.raises(DatasetError, match=f"{png}: image file not found"):
        ds.frame(1)


def test_malformed_rig_and_metadata_yaml(euroc):
    (euroc / "metadata.yaml").write_text("status: [complete\n")
    one_line_error(euroc, r"metadata.yaml: YAML syntax error")


def test_malformed_kitti_times(tmp_path):
    s = Synth(n_frames=3)
    s.write(KittiWriter(tmp_path / "k", s.rig, s.metadata))
    (tmp_path / "k/sequences/00/times_ns.txt").write_text("5\nabc\n7\n")
    one_line_error(tmp_path / "k", r"times_ns.txt: line 2: expected a number")


def test_writer_refuses_complete_folder_and_foreign_folder(euroc, tmp_path):
    s = Synth(n_frames=3)
    with pytest.raises(SimError, match="complete dataset is already there"):
        EurocWriter(euroc, s.rig, s.metadata)
    (tmp_path / "foreign").mkdir()
    (tmp_path / "foreign" / "notes.txt").write_text("mine")
    with pytest.raises(SimError, match="holds no dataset"):
        EurocWriter(tmp_path / "foreign", s.rig, s.metadata, overwrite=True)
    w = EurocWriter(euroc, s.rig, s.metadata, overwrite=True)       # overwrite starts afresh
    assert w.resumed_frames == 0 and (euroc / "INCOMPLETE").exists() and not (euroc / "metadata.yaml").exists()


def test_vo_dataset_does_not_import_mujoco():
    code = ("import sys, vo.dataset, vo.dataset.euroc_reader, vo.dataset.kitti_reader, vo.dataset.open, sim.writers; "
            "print('mujoco' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"
