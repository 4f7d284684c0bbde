"""Short runs: ``motion.start_speed_mps`` (the vehicle may start moving) and no GCP file our tools reject."""
from __future__ import annotations

import numpy as np
import pytest

from sim.errors import SimError
from sim.motion import MotionConfig, SpeedProfile


def _profile(v0):
    return SpeedProfile.build(100.0, 1.2, 0.5, 0.0, 0.0, v_start=v0)


@pytest.mark.parametrize("v0", [0.0, 0.7, 1.2])
def test_speed_profile_from_start_speed_is_smooth_and_ends_at_the_route_end(v0):
    p = _profile(v0)
    s, sd, sdd, _ = p(np.array([0.0, p.duration]))
    assert s[0] == 0.0 and sd[0] == pytest.approx(v0, abs=1e-15)
    assert s[1] == pytest.approx(100.0, abs=1e-9) and sd[1] == 0.0
    # Central differences of s and s' match s' and s'' everywhere, across the phase boundaries (C2 at
    # least): step 1e-4 s, errors O(h^2 * s''') ~ 1e-9, tolerance 1e-6.
    t = np.linspace(1e-3, p.duration - 1e-3, 4001)
    h = 1e-4
    s_p, sd_p, _, _ = p(t + h)
    s_m, sd_m, _, _ = p(t - h)
    _, sd0, sdd0, _ = p(t)
    assert np.max(np.abs((s_p - s_m) / (2 * h) - sd0)) < 1e-6
    assert np.max(np.abs((sd_p - sd_m) / (2 * h) - sdd0)) < 1e-6
    assert np.max(np.abs(sdd0)) <= 0.5 + 1e-12                 # peak acceleration as the route asks


def test_start_speed_zero_keeps_the_profile_from_rest():
    p = _profile(0.0)
    assert p.t_ramp_up == p.t_ramp == pytest.approx(35 / 16 * 1.2 / 0.5)
    assert p.duration == pytest.approx(2 * p.t_ramp + p.t_cruise)


def test_start_speed_is_validated():
    with pytest.raises(SimError, match="motion.start_speed_mps: 1.5 exceeds the route's cruise speed"):
        SpeedProfile.build(100.0, 1.2, 0.5, 0.0, 0.0, v_start=1.5)
    with pytest.raises(SimError, match="too fast to stop"):
        SpeedProfile.build(0.5, 1.2, 0.5, 0.0, 0.0, v_start=1.0)
    with pytest.raises(SimError, match="cannot rest first"):
        MotionConfig(start_speed_mps=1.0, rest_before_s=2.0)
    with pytest.raises(SimError, match="motion.start_speed_mps: must be a non-negative"):
        MotionConfig(start_speed_mps=-1.0)


def test_three_seconds_at_start_speed_cover_the_distance_and_no_empty_gcp_file(tmp_path):
    # From rest, 3 s of campus cover ~0.39 m; at the route's cruise speed 1.2 m/s from the start they
    # cover 3.6 m (planar; vibration adds < 1 %). No check point is reached in either: no gcps.csv
    # (an empty one is rejected by `eval --gcps`), and metadata.yaml says why.
    from rigs.config_io import read_yaml_file
    from sim.generate_config import GenerateConfig
    from sim.generate import generate
    runs = {}
    for name, over in (("rest", ()), ("moving", ("motion.start_speed_mps=1.2",))):
        cfg = GenerateConfig(scene="campus", duration_s=3.0, images=False).with_overrides(over)
        runs[name] = generate(cfg, tmp_path / name, progress=False)
        meta = read_yaml_file(tmp_path / name / "metadata.yaml")
        assert not (tmp_path / name / "gcps.csv").exists() and meta["n_gcps"] == 0
        assert "gcps.csv not written" in meta["gcps"]
    assert runs["rest"].path_length_m < 0.5
    assert runs["moving"].path_length_m == pytest.approx(3.6, rel=0.01)
