"""Our ATE/RPE give evo's figures on the same TUM files (evo 1.38 is the reference implementation)."""
import numpy as np
import pytest

evo_metrics = pytest.importorskip("evo.core.metrics")
from evo.core import sync  # noqa: E402
from evo.tools import file_interface  # noqa: E402

from vo.eval import align, associate, ate, rpe  # noqa: E402
from rigs.geometry import make_T, so3_exp  # noqa: E402
from rigs.trajectory import Trajectory  # noqa: E402
from rigs.trajfile import read_tum, write_tum  # noqa: E402

REL = 1e-9  # both read the same 9-decimal files; differences are float rounding only


@pytest.fixture(scope="module")
def tum_files(tmp_path_factory):
    rng = np.random.default_rng(42)
    n = 400
    t_ns = 1_600_000_000_000_000_000 + np.arange(n, dtype=np.int64) * 50_000_000      # 20 Hz
    yaw = np.cumsum(rng.normal(0, 0.02, n))
    p = np.cumsum(np.c_[0.4 * np.cos(yaw), 0.4 * np.sin(yaw), rng.normal(0, 0.01, n)], axis=0)
    T_gt = np.array([make_T(so3_exp([0, 0, y]), q) for y, q in zip(yaw, p)])
    T_est = np.array([make_T(so3_exp([0, 0, y] + rng.normal(0, 0.01, 3)), q + rng.normal(0, 0.05, 3))
                      for y, q in zip(yaw, p)])
    T_est = np.einsum("ij,njk->nik", make_T(so3_exp([0.1, -0.2, 0.5]), [3.0, -1.0, 0.2]), T_est)
    d = tmp_path_factory.mktemp("evo")
    write_tum(d / "gt.txt", Trajectory(t_ns, T_gt))
    write_tum(d / "est.txt", Trajectory(t_ns[::2] + 1_000_000, T_est[::2]))               # 10 Hz, 1 ms late
    return d / "gt.txt", d / "est.txt"


def _ours(files):
    return associate(read_tum(files[0]), read_tum(files[1]), max_diff_ns=10_000_000)


def _evo(files):
    ref = file_interface.read_tum_trajectory_file(str(files[0]))
    est = file_interface.read_tum_trajectory_file(str(files[1]))
    return sync.associate_trajectories(ref, est, max_diff=0.01)


def _check(ours_stats, evo_metric):
    s = evo_metric.get_all_statistics()
    for key in ("rmse", "mean", "median", "std", "min", "max"):
        assert getattr(ours_stats, key) == pytest.approx(s[key], rel=REL, abs=1e-14), key


@pytest.mark.parametrize("delta,unit", [(1, "frames"), (7, "frames"), (2.0, "m"), (10.0, "m")])
def test_rpe_matches_evo(tum_files, delta, unit):
    gt, est = _ours(tum_files)
    ref_e, est_e = _evo(tum_files)
    assert len(gt) == ref_e.num_poses == 200
    ours = rpe(gt, est, delta, unit)
    U = evo_metrics.Unit.frames if unit == "frames" else evo_metrics.Unit.meters
    for relation, ours_stats in ((evo_metrics.PoseRelation.translation_part, ours.trans),
                                 (evo_metrics.PoseRelation.rotation_angle_deg, ours.rot_deg)):
        m = evo_metrics.RPE(relation, delta=delta, delta_unit=U, all_pairs=False)
        m.process_data((ref_e, est_e))
        assert ours.pairs[:, 1].tolist() == m.delta_ids
        _check(ours_stats, m)


def test_ate_se3_matches_evo(tum_files):
    gt, est = _ours(tum_files)
    ref_e, est_e = _evo(tum_files)
    est_e.align(ref_e, correct_scale=False)
    ours = ate(gt, align(est, gt, "se3")[0])
    for relation, ours_stats in ((evo_metrics.PoseRelation.translation_part, ours.trans),
                                 (evo_metrics.PoseRelation.rotation_angle_deg, ours.rot_deg)):
        m = evo_metrics.APE(relation)
        m.process_data((ref_e, est_e))
        # Umeyama solved twice by different code: agreement to ~1e-12 relative is expected; 1e-9 asked
        _check(ours_stats, m)
