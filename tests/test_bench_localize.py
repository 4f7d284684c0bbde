"""``vo-testbed bench localize --pair K --poses FILE``: the previous site's pose is read from a
``localize`` run's TUM file at the site time; a file without that time is refused naming itself."""
import numpy as np
import pytest

from rigs.geometry import make_T, rot_z
from sim.app.bench_localize import previous_poses
from vo.errors import DatasetError
from rigs.trajectory import Trajectory
from rigs.trajfile import write_tum


def test_previous_poses_are_the_file_poses_at_the_site_times(tmp_path):
    t_ns = np.array([2_000_000_000, 68_938_800_556, 138_479_568_566], np.int64)
    T = np.array([make_T(rot_z(0.3 * k), [k * 8.5, -0.2 * k, 0.01 * k]) for k in range(3)])
    path = tmp_path / "site_poses_tum.txt"
    write_tum(path, Trajectory(t_ns, T, ref="w", frame="b"))
    got = previous_poses(path, t_ns[[2, 0]])
    assert np.allclose(got, T[[2, 0]], atol=1e-8)
    with pytest.raises(DatasetError, match="site_poses_tum.txt: no pose at the site time 100000000000 ns"):
        previous_poses(path, np.array([100_000_000_000], np.int64))


def test_poses_without_pair_is_a_usage_error(tmp_path):
    from click.testing import CliRunner
    from sim.app.cli import cli
    poses = tmp_path / "site_poses_tum.txt"
    poses.write_text("")
    (tmp_path / "metadata.yaml").write_text("kind: traverse\n")
    res = CliRunner().invoke(cli, ["bench", "localize", "--dataset", str(tmp_path), "--poses", str(poses)])
    assert res.exit_code == 2 and "--poses needs --pair" in res.output
