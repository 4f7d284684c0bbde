"""Wheel odometry end to end: generate writes wheels.csv with the vehicle's geometry, the reader API
returns it (ds.wheels), and a wheel override that disagrees with the vehicle is refused."""
import numpy as np
import pytest

from sim.generate_config import GenerateConfig
from sim.errors import SimError
from sim.generate import generate
from sim.vehicles import CART
from vo.dataset.open import open_dataset
from vo.dataset.wheels import read_wheels_csv


def test_reader_returns_the_generated_wheel_ticks(tmp_path):
    """3 s of campus, no images: ticks at 50 Hz; their distance is the trajectory's path length (the
    route is flat, so wheel travel = path length to the tick size 2 pi 0.12 / 1024 = 0.7 mm, plus the
    yaw-rate terms that cancel in the mean of both wheels)."""
    cfg = GenerateConfig(scene="campus", duration_s=3.0, images=False).with_overrides(("wheels=default",))
    res = generate(cfg, tmp_path / "ds", progress=False)
    ds = open_dataset(tmp_path / "ds")
    w = ds.wheels
    assert w is not None and w.t_ns.dtype == np.int64 and np.all(np.diff(w.t_ns) == 20_000_000)
    assert ds.rig.wheels.track_width == CART.track_m and ds.rig.wheels.wheel_radius == CART.wheel_radius_m
    rev = (w.left_ticks[-1] + w.right_ticks[-1]) / 2 / ds.rig.wheels.ticks_per_rev
    assert rev * 2 * np.pi * CART.wheel_radius_m == pytest.approx(res.path_length_m, abs=2e-3)


def test_dataset_without_wheels_and_bad_files(tmp_path):
    assert read_wheels_csv(tmp_path / "wheels.csv") is None
    (tmp_path / "wheels.csv").write_text("#timestamp [ns],left_ticks,right_ticks\n1,0,0\n1,2,2\n")
    from vo.errors import DatasetError
    with pytest.raises(DatasetError, match="increase strictly"):
        read_wheels_csv(tmp_path / "wheels.csv")


def test_wheel_geometry_override_that_disagrees_with_the_vehicle_is_refused(tmp_path):
    cfg = GenerateConfig(scene="campus", duration_s=1.0, images=False).with_overrides(
        ("wheels=default", "wheels.track_width=0.7"))
    with pytest.raises(SimError, match=r"wheels\.track_width: 0\.7"):
        generate(cfg, tmp_path / "ds", progress=False)
