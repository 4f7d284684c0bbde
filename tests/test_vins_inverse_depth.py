"""Seed 002 eq. 14-19: the inverse-depth unit-sphere factor and the window's inverse-depth landmarks."""
import gtsam
import numpy as np
import pytest
from gtsam.symbol_shorthand import L, X

from rigs.geometry import R_from_opk_deg, inv_T, make_T
from rigs.model import Camera, Imu
from vo.vins.vins_config import VinsConfig
from vo.vins.feature_tracker import FeatureFrame
from vo.vins.inverse_depth import inverse_depth_factor, inverse_depth_group, inverse_depth_of, point_of, tangent_basis
from vo.vins.window import Window

CAM = Camera("cam0", 640, 480, 500.0, 500.0, 320.0, 240.0,
             T_b_c=make_T(R_from_opk_deg(-90, 0, -90), [0.2, 0.05, 1.0]))
IMU = Imu(T_b_i=make_T(R_from_opk_deg(3, -2, 91), [0.1, -0.3, 0.7]))
T_I_C = inv_T(IMU.T_b_i_array) @ CAM.T_b_c_array


def _scene(rng):
    """Two body poses, a point 8 m in front of the first camera, its normalized observations."""
    T_a = make_T(R_from_opk_deg(*rng.uniform(-20, 20, 3)), rng.normal(0, 1, 3))
    T_j = T_a @ make_T(R_from_opk_deg(*rng.uniform(-5, 5, 3)), [0.3, 0.2, 0.5])
    xy_a = rng.uniform(-0.3, 0.3, 2)
    p_w = point_of(1 / 8.0, xy_a, T_a @ T_I_C)
    p_cj = (inv_T(T_j @ T_I_C) @ np.append(p_w, 1.0))[:3]
    return T_a, T_j, xy_a, p_w, p_cj[:2] / p_cj[2]


def _values(T_a, T_j, rho):
    v = gtsam.Values()
    v.insert(X(0), gtsam.Pose3(T_a))
    v.insert(X(1), gtsam.Pose3(T_j))
    v.insert(L(0), np.array([rho]))
    return v


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_jacobians_match_central_differences(seed):
    """Analytic Jacobians (anchor pose, observing pose, rho) against central differences of the residual on
    gtsam's retractions (step 1e-6: truncation ~1e-12, rounding ~1e-10; tolerance 1e-7 of entries ~1)."""
    rng = np.random.default_rng(seed)
    T_a, T_j, xy_a, _, xy_j = _scene(rng)
    f = inverse_depth_factor(gtsam.noiseModel.Unit.Create(2), X(0), X(1), L(0), xy_a, xy_j + 0.01, T_I_C)
    v = _values(T_a, T_j, 1 / 8.0)
    A, _ = f.linearize(v).jacobian()
    num, eps = np.zeros((2, 13)), 1e-6
    for k in range(13):
        for s in (1.0, -1.0):
            d = np.zeros(13)
            d[k] = s * eps
            vv = gtsam.Values()
            vv.insert(X(0), gtsam.Pose3(T_a).retract(d[:6]))
            vv.insert(X(1), gtsam.Pose3(T_j).retract(d[6:12]))
            vv.insert(L(0), np.array([1 / 8.0 + d[12]]))
            num[:, k] += s * f.unwhitenedError(vv) / (2 * eps)
    assert np.abs(A - num).max() < 1e-7 * max(1.0, np.abs(num).max())
    assert np.abs(A[:, 12]).max() > 1e-3                 # the inverse depth is observed by this pair


def test_residual_is_zero_at_truth_and_an_angle():
    """Zero at the true poses and depth; a 1 cm lateral camera shift of the observer at 5 m is an angle of
    about 0.01 / 5 rad (the residual's unit is radians, 1.5 / 460 rad is eq. 27's sigma)."""
    rng = np.random.default_rng(3)
    T_a, T_j, xy_a, p_w, xy_j = _scene(rng)
    f = inverse_depth_factor(gtsam.noiseModel.Unit.Create(2), X(0), X(1), L(0), xy_a, xy_j, T_I_C)
    assert np.abs(f.unwhitenedError(_values(T_a, T_j, 1 / 8.0))).max() < 1e-12
    T_w_c = T_a @ T_I_C
    p_c = np.array([0.0, 0.0, 5.0])
    f0 = inverse_depth_factor(gtsam.noiseModel.Unit.Create(2), X(0), X(1), L(0), [0.0, 0.0], [0.0, 0.0], T_I_C)
    T_shift = T_w_c @ make_T(np.eye(3), [0.01, 0, 0]) @ inv_T(T_I_C)
    r = f0.unwhitenedError(_values(T_a, T_shift, 1 / p_c[2]))
    assert np.linalg.norm(r) == pytest.approx(np.arctan(0.01 / 5.0), rel=1e-6)


def test_inverse_depth_round_trip_and_tangent_basis():
    rng = np.random.default_rng(4)
    T_a, _, xy_a, p_w, _ = _scene(rng)
    assert inverse_depth_of(p_w, T_a @ T_I_C) == pytest.approx(1 / 8.0, rel=1e-12)
    assert np.isnan(inverse_depth_of(point_of(-0.1, xy_a, T_a @ T_I_C), T_a @ T_I_C))
    for b in (np.array([0.0, 0.0, 1.0]), np.array([1.0, 0.0, 0.0]), np.array([0.6, 0.0, 0.8])):
        BT = tangent_basis(b)
        assert np.allclose(BT @ BT.T, np.eye(2)) and np.allclose(BT @ b, 0.0)


def _window(landmark):
    """Three states moving 1 m along the optical axis (camera = IMU), five points observed by all."""
    cam = Camera("cam0", 640, 480, 460.0, 460.0, 320.0, 240.0, T_b_c=np.eye(4))
    w = Window(VinsConfig(landmark=landmark, robust="none"), cam, np.eye(4), None, None)
    p_w = {1: [0.5, 0.2, 8.0], 2: [-1.0, 0.4, 12.0], 3: [0.8, -0.6, 6.0], 4: [-0.3, -0.9, 15.0], 5: [2.0, 1.0, 20.0]}
    ids = np.array(sorted(p_w))
    for k in range(3):
        xy = np.array([(np.asarray(p_w[i][:2])) / (p_w[i][2] - k) for i in ids])
        ff = FeatureFrame(k, ids, xy * 460.0 + [320.0, 240.0], xy, np.full(len(ids), 1 + k))
        w.add_state(k, ff, True, make_T(np.eye(3), [0, 0, k]), np.zeros(3), gtsam.imuBias.ConstantBias())
    for i in ids:
        w.add_landmark(int(i), p_w[int(i)])
    return w, p_w


def test_window_inverse_depth_landmarks():
    """Anchored at the first observer (no residual there: 2 residuals per landmark for 3 states, 3 with
    Point3; inverse depth groups them by (anchor, observer) pair), world positions recovered exactly, zero
    visual error at the truth."""
    for landmark, per_lm, n_factors in (("inverse-depth", 2, 2), ("point3", 3, 15)):
        w, p_w = _window(landmark)
        fs = w.visual_factors()
        assert len(list(w.observations())) == per_lm * len(p_w) and len(fs) == n_factors
        assert sum(f.dim() for f in fs) == 2 * per_lm * len(p_w)
        for i, p in p_w.items():
            assert np.allclose(w.landmark_w(i), p, atol=1e-12)
        assert max(abs(f.error(w.values)) for f in fs) < 1e-20
    w, _ = _window("inverse-depth")
    assert {k for k, _ in w.anchor.values()} == {w.states[0].k}
    assert w.values.atVector(L(w.lm[3]))[0] == pytest.approx(1 / 6.0)


def test_landmark_options_are_validated():
    from vo.errors import EstimatorError
    with pytest.raises(EstimatorError, match="landmark"):
        VinsConfig.from_options("base", {"experimental.landmark": "inverse_depth"})
    with pytest.raises(EstimatorError, match="min_triangulation_deg"):
        VinsConfig.from_options("base", {"min_triangulation_deg": 90.0})
    assert VinsConfig.from_options("ac-me", {"experimental.landmark": "inverse-depth"}).landmark == "inverse-depth"


@pytest.mark.parametrize("landmark", ["point3", "inverse-depth"])
def test_hold_gauge_undoes_a_yaw_and_shift_of_the_whole_window(landmark):
    """VINS-Mono's double2vector (``hold_gauge``): a rotation about the vertical plus a shift of the whole window
    (the unobservable directions) is undone exactly; a roll of the oldest state is kept (observable)."""
    w, p_w = _window(landmark)
    w.values.update(gtsam.symbol("v", w.states[1].k), np.array([0.0, 0.0, 1.0]))
    before = {key: w.values.atPose3(X(st.k)).matrix() for key, st in enumerate(w.states)}
    vel = w.values.atVector(gtsam.symbol("v", w.states[1].k)).copy()
    T0 = w.values.atPose3(X(w.states[0].k))
    G = make_T(R_from_opk_deg(0, 0, 37), [4.0, -2.0, 0.5])          # yaw 37 deg about z, and a shift
    for st in w.states:
        w.values.update(X(st.k), gtsam.Pose3(G @ w.values.atPose3(X(st.k)).matrix()))
        w.values.update(gtsam.symbol("v", st.k), G[:3, :3] @ w.values.atVector(gtsam.symbol("v", st.k)))
    if landmark == "point3":
        for key in w.lm.values():
            w.values.update(L(key), G[:3, :3] @ w.values.atPoint3(L(key)) + G[:3, 3])
    w._hold_gauge(T0)
    for key, st in enumerate(w.states):
        assert np.allclose(w.values.atPose3(X(st.k)).matrix(), before[key], atol=1e-12)
    assert np.allclose(w.values.atVector(gtsam.symbol("v", w.states[1].k)), vel, atol=1e-12)
    for i, p in p_w.items():
        assert np.allclose(w.landmark_w(i), p, atol=1e-9)
    roll = make_T(R_from_opk_deg(2, 0, 0), [0, 0, 0])
    w.values.update(X(w.states[0].k), gtsam.Pose3(before[0] @ roll))
    w._hold_gauge(T0)
    R0 = w.values.atPose3(X(w.states[0].k)).rotation().matrix()
    assert np.degrees(np.arccos(np.clip((np.trace(R0.T @ before[0][:3, :3]) - 1) / 2, -1, 1))) == \
        pytest.approx(2.0, abs=0.05)


@pytest.mark.parametrize("kind", ["none", "huber", "cauchy"])
def test_group_equals_single_factors_with_gtsam_robust_noise(kind):
    """One group factor of 6 observations (features anchored in X(0), seen in X(1)) gives the same linear
    system (information and gradient) and the same error as 6 single-observation factors, each with gtsam's
    own ``noiseModel.Robust`` (mEstimator on an isotropic sigma). The observations are perturbed by 0 to 20
    sigma, so the robust losses act inside and outside their thresholds."""
    rng = np.random.default_rng(7)
    T_a, T_j, _, _, _ = _scene(rng)
    k = 6
    xy_a = rng.uniform(-0.3, 0.3, (k, 2))
    rho = 1.0 / rng.uniform(4.0, 30.0, k)
    sigma = 1.5 / 460 / rng.uniform(0.5, 2.0, k)
    c = rng.uniform(0.5, 3.0, k)
    xy_j = np.zeros((k, 2))
    for i in range(k):
        p_c = (inv_T(T_j @ T_I_C) @ np.append(point_of(rho[i], xy_a[i], T_a @ T_I_C), 1.0))[:3]
        xy_j[i] = p_c[:2] / p_c[2] + sigma[i] * i * 4.0 * np.array([0.6, -0.8])
    v = gtsam.Values()
    v.insert(X(0), gtsam.Pose3(T_a))
    v.insert(X(1), gtsam.Pose3(T_j))
    for i in range(k):
        v.insert(L(i), np.array([rho[i] * (1.0 + 0.05 * i)]))
    make = {"huber": gtsam.noiseModel.mEstimator.Huber.Create, "cauchy": gtsam.noiseModel.mEstimator.Cauchy.Create}
    singles, group = gtsam.NonlinearFactorGraph(), gtsam.NonlinearFactorGraph()
    for i in range(k):
        base = gtsam.noiseModel.Isotropic.Sigma(2, sigma[i])
        noise = base if kind == "none" else gtsam.noiseModel.Robust.Create(make[kind](c[i]), base)
        singles.add(inverse_depth_factor(noise, X(0), X(1), L(i), xy_a[i], xy_j[i], T_I_C))
    group.add(inverse_depth_group(X(0), X(1), [L(i) for i in range(k)], xy_a, xy_j, T_I_C, sigma, kind, c))
    order = gtsam.Ordering([X(0), X(1)] + [L(i) for i in range(k)])
    H1, g1 = singles.linearize(v).hessian(order)
    H2, g2 = group.linearize(v).hessian(order)
    assert np.abs(H1 - H2).max() < 1e-9 * np.abs(H1).max() and np.abs(g1 - g2).max() < 1e-9 * np.abs(g1).max()
    assert group.error(v) == pytest.approx(singles.error(v), rel=1e-12)
    assert singles.error(v) > 10.0                      # the perturbations are felt
