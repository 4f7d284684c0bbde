"""Bad input from the newcomer's list and the readers' consistency checks: exit 2 and one line naming the
file (docs/bad_input.md). Each case runs through the console entry point as a user would type it."""
from __future__ import annotations

import shutil

import cv2
import numpy as np
import pytest
import yaml

from rigs.errors import RigError
from rigs.presets import get_rig
from rigs.rig_yaml import rig_to_dict
from sim.app.cli import main
from sim.writers import EurocWriter, KittiWriter
from test_dataset_synth import Synth
from vo.dataset import open_dataset
from vo.errors import DatasetError


def vo_testbed(capsys, *args):
    code = 0
    try:
        main([str(a) for a in args])
    except SystemExit as e:
        code = e.code
    out = capsys.readouterr()
    return code, out.out, out.err


def error_line(code, err) -> str:
    """The one ``error:``/``Error:`` line of a run that exited 2 without a traceback."""
    assert code == 2, err
    lines = [ln for ln in err.strip().splitlines() if ln.strip()]
    errors = [ln for ln in lines if ln.startswith(("error:", "Error:"))]
    assert "Traceback" not in err and len(errors) == 1, err
    return errors[0]


@pytest.fixture
def euroc(tmp_path):
    s = Synth(n_frames=5)
    s.write(EurocWriter(tmp_path / "ds", s.rig, s.metadata))
    return tmp_path / "ds", s


@pytest.fixture
def kitti(tmp_path):
    s = Synth(n_frames=5)
    s.write(KittiWriter(tmp_path / "k", s.rig, s.metadata))
    return tmp_path / "k" / "sequences" / "00"


# ---------------------------------------------------------------------------------------------- readers
def test_kitti_missing_image_1_file_is_exit_2(kitti, tmp_path, capsys):
    (kitti / "image_1" / "000002.png").unlink()
    line = error_line(*vo_testbed(capsys, "run", "--dataset", kitti, "--estimator", "klt-pnp", "--out", tmp_path / "o")[::2])
    assert line == (f"error: {kitti / 'image_1' / '000002.png'}: image file not found (1 of the 5 frames in "
                    f"times.txt have no image_1 file)")


def test_kitti_truncated_times_txt_is_exit_2(kitti, tmp_path, capsys):
    (kitti / "times_ns.txt").unlink()                     # as a real KITTI sequence: times.txt only
    times = kitti / "times.txt"
    times.write_text("".join(times.read_text().splitlines(keepends=True)[:3]))
    line = error_line(*vo_testbed(capsys, "run", "--dataset", kitti, "--estimator", "klt-pnp", "--out", tmp_path / "o")[::2])
    assert line == (f"error: {times}: 3 frame times for 5 images in image_0; a truncated times.txt "
                    f"(or extra images)")


def test_image_of_another_size_than_the_rig_names_file_and_sizes(euroc, tmp_path, capsys):
    ds, s = euroc
    right0 = ds / "mav0" / "cam1" / "data" / f"{s.t_frames[0]}.png"
    cv2.imwrite(str(right0), np.zeros((24, 32), np.uint8))
    line = error_line(*vo_testbed(capsys, "run", "--dataset", ds, "--estimator", "klt-pnp", "--out", tmp_path / "o")[::2])
    assert line == (f"error: {right0}: image is 32x24 px, the rig's cam1 (cam1) is 64x48 px; images and "
                    f"calibration disagree")
    shutil.copy(ds / "mav0" / "cam0" / "data" / f"{s.t_frames[0]}.png", right0)
    left3 = ds / "mav0" / "cam0" / "data" / f"{s.t_frames[3]}.png"            # a later frame: found when read
    cv2.imwrite(str(left3), np.zeros((48, 65), np.uint8))
    dataset = open_dataset(ds)
    dataset.frame(2)
    with pytest.raises(DatasetError, match=rf"^{left3}: image is 65x48 px, the rig's cam0 \(cam0\) is 64x48 px"):
        dataset.frame(3)


def test_kitti_right_images_of_another_size(kitti, capsys):
    for k in range(5):
        cv2.imwrite(str(kitti / "image_1" / f"{k:06d}.png"), np.zeros((40, 64), np.uint8))
    with pytest.raises(DatasetError, match=r"image_1/000000.png: image is 64x40 px, the rig's cam1 .* is 64x48 px"):
        open_dataset(kitti)


def test_cam1_stamps_offset_from_cam0_do_not_pair(euroc, tmp_path, capsys):
    ds, s = euroc
    csv = ds / "mav0" / "cam1" / "data.csv"
    rows = csv.read_text().splitlines()
    for r in rows[1:]:                                    # the files follow their new names
        t, name = r.split(",")
        (ds / "mav0" / "cam1" / "data" / name).rename(ds / "mav0" / "cam1" / "data" / f"{int(t) + 1000}.png")
    csv.write_text("\n".join([rows[0]] + [f"{int(r.split(',')[0]) + 1000},{int(r.split(',')[0]) + 1000}.png"
                                          for r in rows[1:]]) + "\n")
    line = error_line(*vo_testbed(capsys, "run", "--dataset", ds, "--estimator", "klt-pnp", "--out", tmp_path / "o")[::2])
    assert "the cameras' timestamps do not pair: none of the 5 cam0 stamps equals one of the 5 cam1 stamps" in line
    assert "1000 ns apart" in line and "no frames" not in line


# ---------------------------------------------------------------------------------------------- run --out
def test_run_out_on_the_dataset_folder_is_refused(euroc, capsys):
    ds, _ = euroc
    before = sorted(p.name for p in ds.iterdir())
    line = error_line(*vo_testbed(capsys, "run", "--dataset", ds, "--estimator", "klt-pnp", "--out", ds)[::2])
    assert line.startswith(f"error: --out {ds}: is the dataset's own folder ({ds}); the run's files (topdown.png")
    code, _, err = vo_testbed(capsys, "run", "--dataset", ds / "mav0", "--estimator", "klt-pnp", "--out", ds)
    assert "is the dataset's own folder" in error_line(code, err)
    assert sorted(p.name for p in ds.iterdir()) == before


# ---------------------------------------------------------------------------------------------- rigs
def _rig_yaml(tmp_path, edit) -> str:
    d = rig_to_dict(get_rig("stereo27"))
    edit(d)
    path = tmp_path / "rig.yaml"
    path.write_text(yaml.safe_dump(d, sort_keys=False))
    return path


def test_rig_with_both_cameras_at_one_position_is_refused(tmp_path, capsys):
    def same_position(d):
        for r in range(3):
            d["cameras"][1]["T_b_c"][r][3] = d["cameras"][0]["T_b_c"][r][3]
    rig = _rig_yaml(tmp_path, same_position)
    code, _, err = vo_testbed(capsys, "generate", "--rig", rig, "--scene", "indoor", "--duration", "0.5",
                              "--no-images", "--out", tmp_path / "o")
    line = error_line(code, err)
    assert "cam0 and cam1 sit at the same position (baseline 0 m); a stereo rig needs a baseline of at least 1e-06 m" \
        in line and str(rig) in line
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("key, value, size", [("cx", 800.0, 752), ("cy", -3.0, 480)])
def test_rig_with_principal_point_outside_the_image_is_refused(tmp_path, capsys, key, value, size):
    rig = _rig_yaml(tmp_path, lambda d: d["cameras"][0].__setitem__(key, value))
    code, _, err = vo_testbed(capsys, "generate", "--rig", rig, "--scene", "indoor", "--duration", "0.5",
                              "--no-images", "--out", tmp_path / "o")
    assert (f"{rig}: cameras[0]: camera 'cam0'.{key}: principal point {value:g} px is outside the image "
            f"(0 to {size} px") in error_line(code, err)


def test_principal_point_on_the_border_is_accepted():
    from rigs.model import Camera
    assert Camera("c", 64, 48, 50.0, 50.0, 0.0, 48.0).cx == 0.0
    with pytest.raises(RigError, match=r"cx: principal point 64.5 px is outside the image"):
        Camera("c", 64, 48, 50.0, 50.0, 64.5, 24.0)


# ---------------------------------------------------------------------------------------------- generate / export / localize
def test_duration_longer_than_the_route_is_said_and_recorded(tmp_path, capsys):
    out = tmp_path / "o"
    code, stdout, err = vo_testbed(capsys, "generate", "--scenario", "smoke", "--duration", "1e9", "--no-images",
                                   "--no-progress", "--out", out)
    assert code == 0, err
    meta = yaml.safe_load((out / "metadata.yaml").read_text())
    done = meta["duration_s"]
    assert 3.0 < done < 1e9 and meta["config"]["duration_s"] == 1e9
    assert f"{done:.1f} s" in stdout
    warning = f"warning: duration_s: 1e+09 s asked for, but the route of indoor ends after {done:.3f} s; " \
              f"{done:.3f} s were generated (metadata.yaml duration_s)"
    assert warning in err.splitlines() and meta["duration_note"] == warning[len("warning: "):]


def test_export_rosbag1_with_a_storage_is_refused(euroc, tmp_path, capsys):
    ds, _ = euroc
    line = error_line(*vo_testbed(capsys, "export", "--dataset", ds, "--to", "rosbag1", "--storage", "sqlite3",
                                  "--out", tmp_path / "x.bag")[::2])
    assert line == ("Error: --storage sqlite3: applies to --to rosbag2 only (a rosbag1 bag is one .bag file in bag "
                    "format 2.0, with no storage plugin); leave it out")
    assert not (tmp_path / "x.bag").exists()


def test_localize_on_a_stereo_sequence_says_what_it_is(euroc, tmp_path, capsys):
    ds, _ = euroc
    line = error_line(*vo_testbed(capsys, "localize", "--dataset", ds, "--out", tmp_path / "o")[::2])
    assert line == (f"error: {ds}: a EuRoC stereo sequence of 5 frames (synthetic), not a stop-and-go traverse; "
                    f"localize needs per-site panoramas (sites/site_NN/) made by `vo-testbed generate --scenario "
                    f"yutu-traverse --out DIR`")
