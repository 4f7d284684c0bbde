"""Named IMU models."""
import pytest

from rigs import RigError
from rigs.imu_models import get_imu_model, imu_model_names


def test_models_have_documented_values():
    assert imu_model_names() == ["euroc-adis16448", "ideal", "paper002", "xsens-mti10"]
    ideal = get_imu_model("ideal")
    assert ideal.rate_hz == 200.0
    assert (ideal.accel_noise_density, ideal.gyro_noise_density, ideal.accel_random_walk,
            ideal.gyro_random_walk) == (0.0, 0.0, 0.0, 0.0)
    e = get_imu_model("euroc-adis16448")
    assert (e.gyro_noise_density, e.gyro_random_walk, e.accel_noise_density, e.accel_random_walk) == \
        (1.6968e-04, 1.9393e-05, 2.0e-3, 3.0e-3)
    p = get_imu_model("paper002")
    assert (p.accel_noise_density, p.gyro_noise_density, p.accel_random_walk, p.gyro_random_walk) == \
        (0.1, 0.01, 0.001, 0.0001)
    # Xsens MTi 10 datasheet: 60 ug/sqrt(Hz), 0.03 deg/s/sqrt(Hz); random walks reach the in-run bias
    # stability (15 ug, 18 deg/h) as Allan deviation K sqrt(tau/3) at tau = 300 s
    x = get_imu_model("xsens-mti10")
    assert x.rate_hz == 200.0
    assert x.accel_noise_density == pytest.approx(60e-6 * 9.80665, rel=1e-12)
    assert x.gyro_noise_density == pytest.approx(0.03 * 3.141592653589793 / 180, rel=1e-12)
    assert x.accel_random_walk * (300 / 3) ** 0.5 == pytest.approx(15e-6 * 9.80665, rel=1e-12)
    assert x.gyro_random_walk * (300 / 3) ** 0.5 == pytest.approx(18 / 3600 * 3.141592653589793 / 180, rel=1e-12)


def test_unknown_model_lists_names():
    with pytest.raises(RigError) as e:
        get_imu_model("adis")
    assert "\n" not in str(e.value) and "'adis'" in str(e.value) and "paper002" in str(e.value)
