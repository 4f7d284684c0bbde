"""key=value overrides."""
import numpy as np
import pytest

from rigs import RigError
from rigs.overrides import apply_overrides
from rigs.presets import get_rig


def test_baseline_keeps_direction_and_c0():
    rig = get_rig("cart27")
    new = apply_overrides(rig, ["baseline=0.063"])
    assert new.baseline == pytest.approx(0.063, abs=1e-15)
    t_old, t_new = rig.T_c0_c1[:3, 3], new.T_c0_c1[:3, 3]
    np.testing.assert_allclose(t_new / np.linalg.norm(t_new), t_old / np.linalg.norm(t_old), atol=1e-15)
    np.testing.assert_allclose(new.T_c0_c1[:3, :3], rig.T_c0_c1[:3, :3], atol=1e-15)
    assert new.cameras[0] == rig.cameras[0] and rig.baseline == pytest.approx(0.28573, abs=5e-6)


def test_imu_and_camera_overrides():
    rig = get_rig("cart27")
    new = apply_overrides(rig, ["imu.rate_hz=400", "camera_rate_hz=30", "cam0.fx=500", "cam1.cx=370",
                                "cameras.fy=501", "imu.gyro_noise_density=1e-4", "wheels.slip_std=0.01",
                                "cam1.k3=0"])
    assert new.imu.rate_hz == 400.0 and new.imu.gyro_noise_density == 1e-4
    assert new.camera_rate_hz == 30.0
    assert new.cameras[0].fx == 500.0 and new.cameras[1].fx == rig.cameras[1].fx
    assert new.cameras[1].cx == 370.0 and new.cameras[0].cx == rig.cameras[0].cx
    assert new.cameras[0].fy == new.cameras[1].fy == 501.0
    assert new.wheels.slip_std == 0.01 and new.cameras[1].dist[4] == 0.0
    assert new.cameras[1].dist[:4] == rig.cameras[1].dist[:4]


def test_imu_model_swap_keeps_mounting():
    rig = get_rig("stereo27")
    new = apply_overrides(rig, ["imu=paper002"])
    assert new.imu.name == "paper002" and new.imu.accel_noise_density == 0.1
    assert new.imu.T_b_i == rig.imu.T_b_i and rig.imu.name == "euroc-adis16448"


@pytest.mark.parametrize("item, expect", [
    ("baseline=-0.1", "override 'baseline=-0.1': baseline: must be a positive finite number, got -0.1"),
    ("baseline=0", "override 'baseline=0': baseline: must be a positive"),
    ("focal=3", "override 'focal=3': focal: unknown key; valid keys: baseline,"),
    ("cam2.fx=3", "override 'cam2.fx=3': cam2.fx: unknown key"),
    ("imu=adis", "override 'imu=adis': imu model 'adis': unknown; valid names: euroc-adis16448, ideal, paper002"),
    ("cameras.width=7.5", "override 'cameras.width=7.5': cameras.width: must be an integer, got 7.5"),
    ("cameras.width=-3", "override 'cameras.width=-3': cameras.width: must be >= 1, got -3"),
    ("camera_rate_hz=.nan", "override 'camera_rate_hz=.nan': camera_rate_hz: must be a finite number, got nan"),
    ("imu.rate_hz=true", "override 'imu.rate_hz=true': imu.rate_hz: must be a finite number, got True"),
    ("wheels.ticks_per_rev=10.5", "override 'wheels.ticks_per_rev=10.5': wheels.ticks_per_rev: must be an integer"),
    ("wheels=some", "override 'wheels=some': wheels: expected none or default, got 'some'"),
    ("cam0.dist=[1, a]", "override 'cam0.dist=[1, a]': cam0.dist[1]: must be a finite number, got 'a'"),
    ("cam0.dist=[1, 2]", "override 'cam0.dist=[1, 2]': camera 'cam0'.dist: expected 4 or 5 finite"),
    ("nonsense", "override 'nonsense': expected key=value"),
])
def test_bad_overrides(item, expect):
    with pytest.raises(RigError) as e:
        apply_overrides(get_rig("stereo27"), [item])
    assert "\n" not in str(e.value) and str(e.value).startswith(expect), str(e.value)


def test_keys_come_from_the_dataclass_fields():
    """Every field of Camera, Imu and Wheels is a key (no hand-kept list), typed by its annotation."""
    import dataclasses
    from rigs.model import Camera, Imu, Wheels
    from rigs.overrides import is_key, valid_keys
    rig = get_rig("stereo27")
    for group, cls in (("imu", Imu), ("wheels", Wheels), ("cameras", Camera), ("cam1", Camera)):
        assert all(is_key(rig, f"{group}.{f.name}") for f in dataclasses.fields(cls))
    assert not is_key(rig, "cam2.fx") and not is_key(rig, "imu.bias") and "cam1.<" in ", ".join(valid_keys(rig))
    new = apply_overrides(rig, ["wheels.ticks_per_rev=2048", "imu.name=mine", "mount=roof",
                                "cam1.dist=[0.1, 0, 0, 0]", "imu.T_b_i=[[1,0,0,0.5],[0,1,0,0],[0,0,1,0],[0,0,0,1]]"])
    assert new.wheels.ticks_per_rev == 2048 and type(new.wheels.ticks_per_rev) is int
    assert new.imu.name == "mine" and new.mount == "roof" and new.cameras[1].dist == (0.1, 0.0, 0.0, 0.0, 0.0)
    assert new.imu.T_b_i[0][3] == 0.5 and new.imu.rate_hz == rig.imu.rate_hz
