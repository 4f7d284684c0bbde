"""VINS sliding window: marginalization (seed 002 §3.4, strategy 1) with a landmark of degenerate depth."""
import gtsam
import numpy as np
import pytest
from gtsam.symbol_shorthand import X

from rigs.records import ImuSamples
from vo.vins.vins_config import VinsConfig
from vo.vins.feature_tracker import FeatureFrame
from vo.vins.imu import GRAVITY, ImuStream, imu_params
from vo.vins.window import Window
from rigs.model import Camera

CAM = Camera("cam0", 640, 480, 460.0, 460.0, 320.0, 240.0, T_b_c=np.eye(4))


def _standing_window(n_states=4, preset="base", count=8, landmark="point3"):
    """A body standing still at the origin (camera = IMU frame, looking along z), exact 200 Hz IMU."""
    t = np.arange(0, int(1e9) * n_states, int(5e6), dtype=np.int64)
    z = np.zeros((len(t), 3))
    imu = ImuSamples(t, z, np.tile([0.0, 0.0, GRAVITY], (len(t), 1)))
    cfg = VinsConfig.from_options(preset, {"experimental.landmark": landmark})
    w = Window(cfg, CAM, np.eye(4), ImuStream(imu), imu_params(cfg))
    p_w = {1: [0.5, 0.2, 8.0], 2: [-1.0, 0.4, 12.0], 3: [0.8, -0.6, 6.0], 4: [-0.3, -0.9, 15.0], 9: [2.0, 1.0, 400.0]}
    ids = np.array(sorted(p_w))
    xy = np.array([np.asarray(p_w[i][:2]) / p_w[i][2] for i in ids])
    for k in range(n_states):
        ff = FeatureFrame(int(t[0] + k * 1e9), ids, xy * 460.0 + [320.0, 240.0], xy, np.full(len(ids), 5 + k))
        w.add_state(ff.t_ns, ff, True, np.eye(4), np.zeros(3), gtsam.imuBias.ConstantBias())
    for i in ids:
        w.add_landmark(int(i), p_w[int(i)])
    w.counts = {int(i): count for i in ids}
    w.priors.append(gtsam.PriorFactorPose3(X(0), gtsam.Pose3(), gtsam.noiseModel.Isotropic.Sigma(6, 1e-3)))
    w.priors.append(gtsam.PriorFactorVector(gtsam.symbol("v", 0), np.zeros(3), gtsam.noiseModel.Isotropic.Sigma(3, 1e-2)))
    return w


@pytest.mark.parametrize("landmark", ["point3", "inverse-depth"])
@pytest.mark.parametrize("n_states, preset, count", [(4, "base", 8), (11, "base", 8), (11, "ac-me", 300)])
def test_marginalization_survives_a_landmark_without_parallax(n_states, preset, count, landmark):
    """The body never moves, so every landmark's depth is unobservable from the images (only the
    bearings constrain it): gtsam's elimination of such a landmark is indeterminate. The weak landmark
    prior keeps the Schur complement defined, also for features tracked 300 times (adaptive weight
    300·s/g_f); the window then optimises to the exact standing state."""
    w = _standing_window(n_states, preset, count, landmark)
    w.marginalize_oldest()
    assert len(w.states) == n_states - 1 and len(w.priors) >= 1
    w.optimize()
    for st in w.states:
        T = w.values.atPose3(X(st.k)).matrix()
        assert np.abs(T[:3, 3]).max() < 1e-6 and np.abs(T[:3, :3] - np.eye(3)).max() < 1e-6


def test_inverse_depth_moves_to_the_next_observer_on_marginalization():
    """VINS-Mono's shift_depth: a feature anchored at the marginalized state continues, anchored at the next
    window state, at the same world point; Point3 landmarks seen by the marginalized state are dropped."""
    w = _standing_window(4, landmark="inverse-depth")
    before = {i: w.landmark_w(i) for i in w.lm}
    w.marginalize_oldest()
    assert set(w.lm) == set(before)
    assert {k for k, _ in w.anchor.values()} == {w.states[0].k}
    for i, p in before.items():
        assert np.allclose(w.landmark_w(i), p, rtol=1e-9)
    w3 = _standing_window(4)
    w3.marginalize_oldest()
    assert not w3.lm
    w3 = _standing_window(4)
    w3.cfg = VinsConfig.from_options("base", {"experimental.shift_depth": True})     # point3: continue at once
    w3.marginalize_oldest()
    assert set(w3.lm) == set(before) and all(np.allclose(w3.landmark_w(i), p) for i, p in before.items())
