"""``--format both`` roots, ``--no-images`` with KITTI, and ``generate --format rosbag1|rosbag2``."""
from __future__ import annotations

import logging

import numpy as np
import pytest

from sim.generate_config import GenerateConfig
from sim.writers import DatasetWriters
from sim.errors import SimError
from test_dataset_synth import Synth
from vo.dataset import open_dataset


def cli(argv, capsys):
    """Run ``vo-testbed ARGV`` in-process -> (exit code, stdout, stderr)."""
    from sim.app.cli import main
    with pytest.raises(SystemExit) as exc:
        main(argv)
    out = capsys.readouterr()
    return exc.value.code, out.out, out.err


def cli_ok(argv, capsys):
    from sim.app.cli import main
    main(argv)                                     # returns normally on success (no sys.exit(0))
    return capsys.readouterr().out


@pytest.mark.parametrize("fmt", ["kitti", "both"])
def test_no_images_with_kitti_is_refused_before_anything_is_written(tmp_path, capsys, fmt):
    with pytest.raises(SimError, match=r"--no-images.*KITTI odometry holds images only"):
        GenerateConfig(images=False, format=fmt)
    out = tmp_path / fmt
    code, _, err = cli(["generate", "--no-images", "--format", fmt, "--duration", "1", "--out", str(out),
                        "--no-progress"], capsys)
    assert code == 2 and err.startswith("error: images: false (--no-images)") and err.count("\n") == 1
    assert not out.exists()


def test_both_root_opens_the_euroc_copy_and_says_so(tmp_path, caplog):
    s = Synth(n_frames=3)
    s.write(DatasetWriters(tmp_path / "root", s.rig, s.metadata, fmt="both"))
    with caplog.at_level(logging.WARNING, logger="vo.dataset"):
        ds = open_dataset(tmp_path / "root")
        open_dataset(tmp_path / "root")                         # said once per folder
    assert ds.kind == "euroc" and ds.root == tmp_path / "root" / "euroc"
    assert np.array_equal(ds.frame_times_ns, s.t_frames)
    said = [r.getMessage() for r in caplog.records if r.name == "vo.dataset"]
    assert len(said) == 1 and "holds euroc/ and kitti/" in said[0] and str(tmp_path / "root" / "euroc") in said[0]


def test_generate_rosbag_writes_euroc_and_bag_with_same_times(tmp_path, capsys):
    # generate --format rosbag2: the EuRoC folder plus rosbag2/ (MCAP) converted from it; the bag's IMU
    # and ground-truth stamps are the dataset's own.
    from rosbags.highlevel import AnyReader
    out = tmp_path / "bag"
    text = cli_ok(["generate", "--no-images", "--format", "rosbag2", "--duration", "1", "--out", str(out),
                   "--no-progress"], capsys)
    assert f"{out} and {out / 'rosbag2'}" in text
    ds = open_dataset(out)
    with AnyReader([out / "rosbag2"]) as reader:
        t_imu = [t for c, t, _ in reader.messages() if c.topic == "/imu0"]
        topics = set(reader.topics)
    assert np.array_equal(t_imu, ds.imu.t_ns) and len(t_imu) == 201          # 1 s at 200 Hz, both ends
    assert {"/imu0", "/groundtruth/pose", "/tf_static"} <= topics


def test_generate_both_names_both_folders_and_run_accepts_the_root(tmp_path, capsys):
    root = tmp_path / "both"
    text = cli_ok(["generate", "--format", "both", "--duration", "1", "--out", str(root), "--no-progress",
                   "--set", "motion.start_speed_mps=1.0"], capsys)
    assert f"to {root / 'euroc'} and {root / 'kitti'} (euroc, kitti)" in text
    run_text = cli_ok(["run", "--dataset", str(root), "--estimator", "rop", "--out", str(tmp_path / "run"),
                       "--no-progress"], capsys)
    assert "11 frames" in run_text and (tmp_path / "run" / "trajectory_tum.txt").is_file()


def test_a_bag_format_without_its_exporter_is_refused_before_writing(tmp_path):
    """The bag export lives in the app layer (it reads the folder through the reader API); the library's generate
    takes it as a collaborator and refuses a bag format without it, in one line, before the folder exists."""
    from sim.errors import SimError
    from sim.generate import generate
    from sim.generate_config import GenerateConfig
    out = tmp_path / "bag"
    with pytest.raises(SimError) as e:
        generate(GenerateConfig(scene="campus", rig="cart27", duration_s=1.0, format="rosbag2", images=False), out,
                 progress=False)
    assert "bag_export" in str(e.value) and "\n" not in str(e.value)
    assert not out.exists()
