"""resume_state counts only complete frames; a resumed run gives the same bytes as one run."""
from __future__ import annotations

import pytest

from sim.writers import EurocWriter, KittiWriter, resume_state
from sim.errors import SimError
from test_dataset_synth import Synth, folder_hashes


def crash_after(writer_cls, out, s, n_done):
    """Write ``n_done`` frames, then half of the next one (cam0 row + PNG, no cam1) and die."""
    w = writer_cls(out, s.rig, s.metadata)
    s.write(w, frames=range(n_done), finalize=False)
    k = n_done
    sl = slice(10 * k, 10 * k + 4)
    w.add_imu(s.t_imu[sl], s.gyro[sl], s.accel[sl])             # some IMU of the next frame
    return w, k


def test_euroc_resume_counts_only_complete_frames(tmp_path):
    s = Synth()
    w, k = crash_after(EurocWriter, tmp_path / "r", s, 3)
    assert resume_state(tmp_path / "r") == 3
    # Partial frame 3: cam0 png + cam0 row written, cam1 missing -> still 3.
    from sim.writers.common import write_png
    write_png(tmp_path / f"r/mav0/cam0/data/{s.t_frames[3]}.png", s.images[3][0])
    w._cams[0].append(s.t_frames[3], [f"{s.t_frames[3]}.png"])
    assert resume_state(tmp_path / "r") == 3
    # A listed frame whose PNG vanished is not complete either.
    (tmp_path / f"r/mav0/cam1/data/{s.t_frames[2]}.png").unlink()
    assert resume_state(tmp_path / "r") == 2


def test_euroc_resumed_run_is_byte_identical_to_single_run(tmp_path):
    s = Synth()
    crash_after(EurocWriter, tmp_path / "r", s, 3)
    w = EurocWriter(tmp_path / "r", s.rig, s.metadata)
    assert w.resumed_frames == 3
    s.write(w)                      # the caller replays everything; frames/IMU already on disk are skipped
    s.write(EurocWriter(tmp_path / "one", s.rig, s.metadata))
    assert folder_hashes(tmp_path / "r") == folder_hashes(tmp_path / "one")


def test_kitti_resumed_run_is_byte_identical(tmp_path):
    s = Synth()
    crash_after(KittiWriter, tmp_path / "r", s, 2)
    assert resume_state(tmp_path / "r") == 2
    w = KittiWriter(tmp_path / "r", s.rig, s.metadata)
    assert w.resumed_frames == 2
    s.write(w)
    s.write(KittiWriter(tmp_path / "one", s.rig, s.metadata))
    assert folder_hashes(tmp_path / "r") == folder_hashes(tmp_path / "one")


def test_resume_with_other_configuration_is_refused(tmp_path):
    s = Synth()
    crash_after(EurocWriter, tmp_path / "r", s, 2)
    with pytest.raises(SimError, match="different configuration"):
        EurocWriter(tmp_path / "r", s.rig, dict(s.metadata, seed=99))


def test_non_increasing_timestamps_are_rejected(tmp_path):
    s = Synth()
    w = EurocWriter(tmp_path / "x", s.rig, s.metadata)
    w.add_imu(s.t_imu[:3], s.gyro[:3], s.accel[:3])
    with pytest.raises(SimError, match="timestamps must increase"):
        w.add_imu(s.t_imu[2:4], s.gyro[2:4], s.accel[2:4])
