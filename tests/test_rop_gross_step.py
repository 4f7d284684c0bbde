"""The ROP step is checked against the track filter's PnP step of the same tracks (vo.rop.moving.TrackFilter)."""
import numpy as np

from rigs.geometry import make_T
from vo.rop.moving import GROSS_STEP_FRACTION, TrackFilter


def _T(x: float) -> np.ndarray:
    return make_T(np.eye(3), [x, 0.0, 0.0])


def test_one_rigid_motion_lets_a_scale_error_through_and_stops_a_gross_step():
    pnp = _T(2.0)                                   # the PnP step: 2 m along x
    f = TrackFilter(None, pnp, 50, 0.0)              # one rigid motion among the tracks
    assert f.step_miss(_T(2.0 * 1.16), pnp, 0.3) == ""            # 16 % long (a miscalibrated rig): stands
    assert f.step_miss(_T(2.0 * (1 - GROSS_STEP_FRACTION) - 0.01), pnp, 0.3) != ""   # off by more than half
    small = _T(0.1)                                  # a 0.1 m step: the absolute gate holds
    assert f.step_miss(_T(0.35), small, 0.3) == ""
    assert "7.70 m" in f.step_miss(_T(7.8), small, 0.3)            # the indoor gross solution


def test_competing_motions_use_the_absolute_gate():
    pnp = _T(2.0)
    f = TrackFilter(np.ones(10, bool), pnp, 50, 0.0)
    assert f.step_miss(_T(2.25), pnp, 0.3) == ""
    assert f.step_miss(_T(2.4), pnp, 0.3) != ""
    assert f.step_miss(_T(9.0), None, 0.3) == ""     # no PnP pose: nothing to compare with
