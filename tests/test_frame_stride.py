"""``vo.dataset.frame_stride.FrameStride``: every Nth frame of a recording, checked frame by frame against the
recording itself, and ``bench real --stride`` on it."""
import json

import numpy as np
import pytest
from click.testing import CliRunner

from sim.app.bench_real import bench_real
from sim.app.cli import cli, main
from sim.errors import SimError
from vo.dataset import open_dataset
from vo.dataset.frame_stride import FrameStride
from vo.errors import DatasetError


def test_view_frames_are_every_nth_frame_of_the_recording(campus_depth_ideal):
    ds = open_dataset(campus_depth_ideal)
    n = len(ds)
    for step in (1, 3, n - 1, n + 5):
        view = FrameStride(ds, step)
        assert len(view) == -(-n // step)                                   # ceil(n / step)
        assert np.array_equal(view.frame_times_ns, ds.frame_times_ns[::step])
        for k in (0, len(view) - 1):
            f, g = view.frame(k), ds.frame(k * step)
            assert f.index == k and f.t_ns == g.t_ns
            assert np.array_equal(f.left, g.left) and np.array_equal(f.right, g.right)
            assert view.image_files(k) == ds.image_files(k * step)
            assert np.array_equal(view.depth(k), ds.depth(k * step))
    view = FrameStride(ds, 3)
    assert [f.index for f in view.frames()] == list(range(len(view)))
    assert [f.t_ns for f in view.frames(1, None, 2)] == list(ds.frame_times_ns[3::6])
    assert view.frame(-1).t_ns == ds.frame_times_ns[3 * (len(view) - 1)]
    assert view.groundtruth is ds.groundtruth and view.rig is ds.rig       # the recording's own, matched by time
    with pytest.raises(DatasetError, match="out of range"):
        view.frame(len(view))
    for bad in (0, -2, 1.5, True, "2"):
        with pytest.raises(DatasetError, match="frame stride"):
            FrameStride(ds, bad)


@pytest.mark.slow
def test_bench_real_stride_runs_on_the_view(campus_short, tmp_path):
    """``--stride 1`` is the recording itself (the same figures to the bit); ``--stride 3`` runs on every third
    frame (its pose count, its label) and its truth is the recording's at those frames."""
    runner = CliRunner()
    res = {}
    for stride in (1, 3):
        r = runner.invoke(cli, ["bench", "real", "--dataset", str(campus_short), "--estimator", "klt-pnp",
                                "--stride", str(stride), "--out", str(tmp_path / f"s{stride}"), "--json"])
        assert r.exit_code == 0, r.output
        res[stride] = json.loads(r.output)[0]
    plain = bench_real([campus_short], ("klt-pnp",), progress=False)[0]
    n = len(open_dataset(campus_short))
    assert res[1]["drift_pct"] == plain.drift_pct and res[1]["n_frames"] == n
    assert res[1]["recording"] == plain.recording and not res[1]["recording"].endswith("stride1")
    s3 = res[3]
    assert s3["n_frames"] == -(-n // 3) and sum(s3["status_counts"].values()) == s3["n_frames"]
    assert s3["recording"] == plain.recording + "-stride3"
    # the truth's path through every third pose: no longer than the full one, and within 1 % of it on this route
    assert s3["path_length_m"] <= plain.path_length_m + 1e-9
    assert s3["path_length_m"] == pytest.approx(plain.path_length_m, rel=0.01)
    assert np.isfinite(s3["drift_pct"])


def test_bench_real_bad_stride_is_refused(tmp_path, capsys):
    with pytest.raises(SystemExit) as e:
        main(["bench", "real", "--dataset", str(tmp_path), "--stride", "0"])
    err = capsys.readouterr().err.strip()
    assert e.value.code == 2 and len(err.splitlines()) == 1 and "--stride" in err, err
    with pytest.raises(SimError, match="stride"):
        bench_real([tmp_path], ("klt-pnp",), stride=0)
