"""VINS visual factor wiring, the adaptive covariance (eq. 22-27), the adaptive Huber (eq. 30), options."""
import gtsam
import numpy as np
import pytest
from gtsam.symbol_shorthand import L, X

from rigs.geometry import R_from_opk_deg, inv_T, make_T
from rigs.model import Camera, Imu, Rig
from vo.errors import EstimatorError
from vo.estimators.registry import make_estimator
from vo.vins.adaptive import geometry_factor, huber_k, noise_model, visual_weight
from vo.vins.vins_config import VinsConfig
from vo.vins.feature_tracker import FeatureFrame
from vo.vins.window import Window

CAM = Camera("cam0", 640, 480, 500.0, 500.0, 320.0, 240.0,
             T_b_c=make_T(R_from_opk_deg(-90, 0, -90), [0.2, 0.05, 1.0]))
IMU = Imu(T_b_i=make_T(R_from_opk_deg(3, -2, 91), [0.1, -0.3, 0.7]))


def test_projection_factor_zero_at_truth_and_sees_errors():
    """Window's reprojection factor (IMU pose key, T_i_c as body_P_sensor, undistorted pixels): zero residual
    at the true IMU pose and point; a 1 cm lateral camera shift at 5 m gives 500 * 0.01 / 5 = 1 px."""
    T_i_c = inv_T(IMU.T_b_i_array) @ CAM.T_b_c_array
    w = Window(VinsConfig(robust="none"), CAM, T_i_c, None, None)
    T_w_i = make_T(R_from_opk_deg(5, 10, 40), [3.0, -2.0, 1.5])
    T_w_c = T_w_i @ T_i_c
    p_c = np.array([0.4, -0.3, 5.0])
    p_w = T_w_c[:3, :3] @ p_c + T_w_c[:3, 3]
    xy = p_c[:2] / p_c[2]
    st = w.add_state(0, FeatureFrame(0, np.array([7]), np.zeros((1, 2)), xy[None], np.array([3])), True,
                     T_w_i, np.zeros(3), gtsam.imuBias.ConstantBias())
    w.add_landmark(7, p_w)
    f = w._factor(st, 7, xy)
    assert np.abs(f.unwhitenedError(w.values)).max() < 1e-9
    T_shift = T_w_c @ make_T(np.eye(3), [0.01, 0, 0]) @ inv_T(T_i_c)
    w.values.update(X(st.k), gtsam.Pose3(T_shift))
    r = f.unwhitenedError(w.values)
    assert abs(np.linalg.norm(r) - 500 * 0.01 / 5.0) < 1e-3, r
    assert w.values.exists(L(w.lm[7]))


def test_geometry_factor_matches_pdop():
    """eq. 22-25: six features on the +-x, +-y, +-z axes (any ranges): H^T H = 2 I, g_f = sqrt(3/2)."""
    cam = np.array([1.0, 2.0, 3.0])
    dirs = np.vstack([np.eye(3), -np.eye(3)]) * np.array([2.0, 5.0, 9.0, 1.0, 3.0, 7.0])[:, None]
    assert geometry_factor(cam + dirs, cam) == pytest.approx(np.sqrt(1.5), rel=1e-12)
    # features bunched in a narrow forward cone (paper Fig. 6b) have a worse (larger) g_f than spread ones
    rng = np.random.default_rng(0)
    def cone(half_angle):
        a = rng.uniform(-half_angle, half_angle, (100, 2))
        return np.column_stack([np.tan(a[:, 0]), np.tan(a[:, 1]), np.ones(100)]) * 10.0
    assert geometry_factor(cone(0.1), np.zeros(3)) > 3 * geometry_factor(cone(0.6), np.zeros(3))
    assert np.isnan(geometry_factor(np.ones((2, 3)), np.zeros(3)))


@pytest.mark.parametrize("preset, g_f, n, weight", [
    ("base", 0.5, 10, 1.0),                      # eq. 27: fixed 1.5 px at F_c = 460
    ("ac-gf", 0.5, 10, 2.0),                     # 1 / g_f
    ("ac", 0.5, 10, 10 * 0.02 / 0.5),            # N s / g_f (eq. 26)
    ("ac-me", 0.5, 40, 40 * 0.02 / 0.5),
])
def test_adaptive_weight_and_sigma(preset, g_f, n, weight):
    cfg = VinsConfig.from_options(preset, {})
    assert visual_weight(cfg, g_f, n) == pytest.approx(weight)
    base = noise_model(cfg, g_f, n, fx=920.0)
    sigma = 1.5 / 460.0 * 920.0 / weight
    inner = base.noise() if hasattr(base, "noise") else base
    assert inner.sigmas() == pytest.approx([sigma, sigma])


def test_huber_thresholds():
    assert huber_k(VinsConfig.from_options("ac-me", {}), 35) == pytest.approx(0.02 * 35)     # eq. 30
    assert huber_k(VinsConfig.from_options("huber", {"robust_k": 1.5}), 35) == 1.5
    assert huber_k(VinsConfig.from_options("base", {}), 35) is None
    # the robust model is applied to the whitened residual: weight 1 inside k, k/|e| outside
    m = noise_model(VinsConfig.from_options("ac-me", {}), 0.5, 50, fx=460.0)    # k = 1
    assert m.robust().weight(0.5) == pytest.approx(1.0) and m.robust().weight(4.0) == pytest.approx(0.25)


def _pull(cfg, g_f, n, e_px, fx=460.0, h=1e-4):
    """d(cost)/d(pixel residual) of one observation with residual ``e_px`` (central difference)."""
    m = noise_model(cfg, g_f, n, fx)
    c = [m.loss(m.squaredMahalanobisDistance(np.array([e, 0.0]))) for e in (e_px - h, e_px + h)]
    return (c[1] - c[0]) / (2 * h)


def test_adaptive_huber_threshold_in_pixels_is_n_free_and_its_pull_grows_as_n_squared():
    """With M_s = s (Table 1: both 0.02) the whitened threshold M_s·N times the residual sigma
    1.5·g_f/(s·N) (virtual px) is 1.5·g_f px for every N; beyond it the pull is k/sigma =
    M_s·s·N²/(1.5·g_f) per px. Cauchy (scale 1, vins-ac) instead falls off as 1/e for every N."""
    me, ac = VinsConfig.from_options("ac-me", {}), VinsConfig.from_options("ac", {})
    g_f = 2.0
    for n in (5, 20, 60):
        k_px = huber_k(me, n) * 1.5 / visual_weight(me, g_f, n)
        assert k_px == pytest.approx(1.5 * g_f)
        for e in (4.0, 30.0):                                  # beyond 1.5·g_f = 3 px: constant pull
            assert _pull(me, g_f, n, e) == pytest.approx(0.02 * 0.02 * n * n / (1.5 * g_f), rel=1e-4)
    assert _pull(me, g_f, 60, 30.0) / _pull(me, g_f, 5, 30.0) == pytest.approx(144.0, rel=1e-4)
    for n in (5, 60):                                          # Cauchy: 1/e for e >> sigma, any N
        assert _pull(ac, g_f, n, 3000.0) == pytest.approx(1 / 3000.0, rel=0.02)
@pytest.mark.parametrize("options, match", [
    ({"window_size": 2}, r"vins\.window_size: must be >= 3, got 2"),
    ({"robust": "tukey"}, r"vins\.robust: unknown 'tukey'; valid: none, cauchy, huber, adaptive-huber"),
    ({"s": 0}, r"vins\.s: must be a positive number, got 0"),
    ({"imu_noise": "fast"}, r"vins\.imu_noise: unknown 'fast'; valid: rig, table1"),
    ({"init_keyframes": 20}, r"vins\.init_keyframes: must be <= window_size \(11\), got 20"),
    ({"bogus": 1}, r"vins\.bogus: unknown key; valid keys: use_gf, "),
    ({"init": "gps"}, r"vins\.init: unknown 'gps'; valid: vi, truth"),
    ({"covariance": "every"}, r"vins\.covariance: unknown 'every'; valid: frame, off"),
    ({"init_min_keyframes": 12}, r"vins\.init_min_keyframes: must be <= init_keyframes \(11\), got 12"),
    ({"experimental.weight_max": True}, r"vins\.weight_max: must be a positive number or \.inf, got True"),
    ({"experimental": {"weight_min": 2.0, "weight_max": 1.0}}, r"vins\.weight_min: must be below weight_max \(1\.0\), got 2\.0"),
])
def test_bad_options_are_one_line_errors(options, match):
    with pytest.raises(EstimatorError, match=match) as e:
        VinsConfig.from_options("base", options)
    assert "\n" not in str(e.value)


def test_registered_and_needs_imu():
    rig = Rig("mono-imu", (CAM,), imu=IMU)
    for name in ("vins", "vins-ac-gf", "vins-ac", "vins-ac-me", "vins-huber", "vins-oracle"):
        assert make_estimator(name, rig).name == name
    est = make_estimator("vins", rig)
    with pytest.raises(EstimatorError, match="imu0"):
        est.set_imu(None)
    with pytest.raises(EstimatorError, match="imu0"):          # process() before any IMU was given
        est.process(None)


def test_n_count_track_or_window():
    """N of eq. 26/30: ``track`` = the front-end's times tracked (uncapped), ``window`` = the number of window
    states observing the feature (VINS-Mono's used_num). A feature tracked 40 times and seen by 2 of the 3
    states gets sigma 1.5/460*fx/(40*0.02) resp. 1.5/460*fx/(2*0.02) (vins-ac, no g_f: fewer than 3 points)."""
    T_i_c = inv_T(IMU.T_b_i_array) @ CAM.T_b_c_array
    sig = {}
    for mode in ("track", "window"):
        cfg = VinsConfig(use_gf=True, use_track_count=True, robust="none", n_count=mode)
        w = Window(cfg, CAM, T_i_c, None, None)
        for k, ids in enumerate(([5, 7], [7], [5, 7])):
            n = len(ids)
            ff = FeatureFrame(k, np.array(ids), np.zeros((n, 2)), np.zeros((n, 2)), np.array([38 + k] * n))
            w.add_state(k, ff, True, make_T(np.eye(3), [0, 0, k]), np.zeros(3), gtsam.imuBias.ConstantBias())
        w.add_landmark(5, [0.0, 0.0, 10.0])
        fs = w.visual_factors(states=w.states[-1:], tracks={5})
        assert len(fs) == 1
        sig[mode] = fs[0].noiseModel().sigmas()[0]
    base = 1.5 / 460 * CAM.fx
    assert sig["track"] == pytest.approx(base / (40 * 0.02), rel=1e-9)
    assert sig["window"] == pytest.approx(base / (2 * 0.02), rel=1e-9)
    with pytest.raises(EstimatorError, match="n_count"):
        VinsConfig(n_count="frames")


def test_landmarks_seen_once_in_the_window_are_dropped():
    """A landmark observed by a single window state (its other observer was dropped) carries no depth
    information and would make the linear system indeterminate: it is removed before optimising."""
    T_i_c = inv_T(IMU.T_b_i_array) @ CAM.T_b_c_array
    w = Window(VinsConfig(), CAM, T_i_c, None, None)
    for k, ids in enumerate(([5, 7], [7])):
        n = len(ids)
        ff = FeatureFrame(k, np.array(ids), np.zeros((n, 2)), np.zeros((n, 2)), np.ones(n, np.int64))
        w.add_state(k, ff, True, make_T(np.eye(3), [0, 0, k]), np.zeros(3), gtsam.imuBias.ConstantBias())
    w.add_landmark(5, [0.0, 0.0, 10.0])
    w.add_landmark(7, [1.0, 0.0, 10.0])
    w._drop_single_observations()
    assert set(w.lm) == {7}
    assert not w.values.exists(L(0)) and w.values.exists(L(1))


# seed 002 Table 2/3 columns (plus the Huber comparison and the oracle), as the five classes defined them
REGISTERED_CONFIGS = {
    "vins": dict(use_gf=False, use_track_count=False, robust="cauchy", remove_dynamic=False),
    "vins-ac-gf": dict(use_gf=True, use_track_count=False, robust="cauchy", remove_dynamic=False),
    "vins-ac": dict(use_gf=True, use_track_count=True, robust="cauchy", remove_dynamic=False),
    "vins-ac-me": dict(use_gf=True, use_track_count=True, robust="adaptive-huber", remove_dynamic=False),
    "vins-huber": dict(use_gf=False, use_track_count=False, robust="huber", remove_dynamic=False),
    "vins-oracle": dict(use_gf=False, use_track_count=False, robust="cauchy", remove_dynamic=True),
}


@pytest.mark.parametrize("name", sorted(REGISTERED_CONFIGS))
def test_registered_names_are_vins_presets(name):
    """Each registered VINS name is ``vins`` with its preset: the configuration it always had (every other field
    the default), the same as ``vins`` with ``preset=<name without vins->``, an oracle only where it reads truth;
    options still apply on top, and a name's fixed preset cannot be overridden."""
    from dataclasses import fields
    from vo.estimators.registry import is_oracle
    rig = Rig("mono-imu", (CAM,), imu=IMU)
    est = make_estimator(name, rig)
    expected = REGISTERED_CONFIGS[name]
    default = VinsConfig()
    assert type(est).__name__ == "VinsEstimator" and est.name == name
    assert {f.name: getattr(est.config, f.name) for f in fields(VinsConfig)} == {
        f.name: expected.get(f.name, getattr(default, f.name)) for f in fields(VinsConfig)}
    preset = "base" if name == "vins" else name[len("vins-"):]
    assert make_estimator("vins", rig, preset=preset).config == est.config
    assert is_oracle(name) == (name == "vins-oracle") and is_oracle(name, {"init": "truth"})
    assert make_estimator(name, rig, experimental={"landmark": "inverse-depth"}).config.landmark == "inverse-depth"
    if name != "vins":
        with pytest.raises(EstimatorError, match="preset"):
            make_estimator(name, rig, preset="base")
