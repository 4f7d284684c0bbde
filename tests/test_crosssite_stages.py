"""Seed 001 §2 stages on plain arrays: the Wallis filter (eq. 1, corrected r0) reaches its predicted
statistics; ZNCC + median + LSM stereo matching recovers known disparities of a warped texture to
sub-pixel accuracy (against the 1/3 px the paper assumes); the distance-consistency test (eq. 2)
removes planted outliers; the ASIFT tilt set shrinks with the predicted transition tilt."""
import cv2
import numpy as np
import pytest

from rigs.geometry import make_T, rot_y, rot_z
from vo.crosssite.asift import SQRT2, tilt_set, transition, view_params
from vo.crosssite.localizer_config import CrossSiteConfig
from vo.crosssite.distance_test import distance_consistency
from vo.crosssite.wallis import local_stats, wallis, wallis_coefficients
from vo.crosssite.zncc import match_stereo
from vo.errors import VoError


def texture(rng, H, W, blur=1.5):
    tex = cv2.GaussianBlur(rng.standard_normal((H // 2, W // 2)), (0, 0), blur)
    tex = cv2.resize(tex, (W, H), interpolation=cv2.INTER_CUBIC)
    return 128 + 40 * tex / tex.std()


@pytest.mark.parametrize("b,c", [(1.0, 1.0), (1.0, 4.0), (0.6, 2.0)])
def test_wallis_global_statistics_are_the_predicted_ones(b, c):
    """Global window: mean ``b m_f + (1 - b) m_g`` and std ``r1 s_g`` exactly (float output)."""
    g = np.clip(texture(np.random.default_rng(0), 200, 300) * 0.5 + 30, 0, 255)
    m_g, s_g = g.mean(), g.std()
    out = wallis(g, 140.0, 50.0, b=b, c=c, window_px=None, out_float=True)
    r1, _ = wallis_coefficients(m_g, s_g, 140.0, 50.0, b, c)
    assert out.mean() == pytest.approx(b * 140.0 + (1 - b) * m_g, abs=1e-9)
    assert out.std() == pytest.approx(r1 * s_g, rel=1e-12)
    assert r1 * s_g == pytest.approx(c * 50.0 * s_g / (c * s_g + 50.0 / c))


def test_wallis_large_c_reaches_the_target_std_and_levels_local_contrast():
    """``r1 s_g -> s_f`` as c grows; locally: an image whose contrast ramps 5x across it comes out with
    the same mean local std at both ends (within 10 %) where the input's differs > 2.5x."""
    g = texture(np.random.default_rng(1), 256, 512)
    out = wallis(g, 128.0, 30.0, b=1.0, c=50.0, window_px=None, out_float=True)
    assert out.std() == pytest.approx(30.0, rel=2e-3) and out.mean() == pytest.approx(128.0, abs=1e-9)
    ramp = 128 + (g - 128) * np.linspace(0.2, 1.0, 512)[None, :]
    lo = wallis(ramp, 128.0, 30.0, b=1.0, c=50.0, window_px=31, out_float=True)
    s_out, s_in = local_stats(lo, 31)[1], local_stats(ramp, 31)[1]
    left, right = np.s_[40:-40, 40:150], np.s_[40:-40, -150:-40]
    assert s_in[right].mean() / s_in[left].mean() > 2.5
    assert s_out[right].mean() / s_out[left].mean() == pytest.approx(1.0, abs=0.1)


def test_wallis_rejects_bad_parameters():
    with pytest.raises(VoError, match="window_px"):
        wallis(np.zeros((10, 10)), 100, 20, window_px=4)
    with pytest.raises(VoError, match="s_f"):
        wallis(np.zeros((10, 10)), 100, 0.0)


def test_zncc_lsm_recovers_known_disparities_subpixel():
    """Right image = left warped by d(v) = 20 + 60 v / H (cubic): after ZNCC, the median filter and
    LSM the disparity error has sigma_p < 0.05 px, well under the paper's 1/3 px; ZNCC alone is only
    integer-accurate (its error is uniform in +-0.5 px, sigma ~0.29 px)."""
    rng = np.random.default_rng(2)
    H, W = 480, 640
    left = texture(rng, H, W)
    yy, xx = np.mgrid[0:H, 0:W].astype(np.float32)
    d = (20 + 60 * yy / H).astype(np.float32)
    right = cv2.remap(left.astype(np.float32), xx + d, yy, cv2.INTER_CUBIC)
    L8, R8 = (np.clip(np.rint(a), 0, 255).astype(np.uint8) for a in (left, right))
    pts = cv2.goodFeaturesToTrack(L8, 300, 0.01, 10).reshape(-1, 2).astype(float)
    pts += rng.uniform(-0.5, 0.5, pts.shape)
    cfg = CrossSiteConfig(range_min_m=1.0)
    true = 20 + 60 * pts[:, 1] / H
    m = match_stereo(L8, R8, pts, 500.0, 0.2, cfg)
    err = (pts[:, 0] - m.uv_r[:, 0] - true)[m.ok]
    assert m.ok.sum() > 0.7 * len(pts)
    assert np.std(err) < 0.05 and np.abs(err).max() < 0.2
    m0 = match_stereo(L8, R8, pts, 500.0, 0.2, cfg, refine=False)
    err0 = (pts[:, 0] - m0.uv_r[:, 0] - true)[m0.ok]
    assert 0.2 < np.std(err0) < 0.35


def test_median_filter_drops_a_wrong_disparity():
    """A repeated pattern makes ZNCC pick the wrong period for some points; a planted wrong point
    (its right image patch replaced) must be rejected while the consistent ones pass."""
    rng = np.random.default_rng(4)
    H, W = 240, 400
    left = texture(rng, H, W)
    right = np.roll(left, -30, axis=1)
    right[100:130, 180:220] = texture(np.random.default_rng(9), 30, 40)   # occluded: no true match
    L8, R8 = (np.clip(np.rint(a), 0, 255).astype(np.uint8) for a in (left, right))
    pts = np.array([[x, y] for x in range(60, 360, 25) for y in range(30, 210, 25)], float)
    m = match_stereo(L8, R8, pts, 500.0, 0.2, CrossSiteConfig(range_min_m=1.0, zncc_min=0.0))
    bad = (pts[:, 0] - 30 >= 180 - 7) & (pts[:, 0] - 30 < 220 + 7) & (pts[:, 1] >= 100 - 7) & (pts[:, 1] < 130 + 7)
    d = pts[:, 0] - m.uv_r[:, 0]
    assert np.all(np.abs(d[m.ok] - 30) < 0.2)
    assert m.ok[~bad].mean() > 0.9


def test_distance_consistency_removes_planted_outliers():
    """60 inliers seen at two sites related by a rigid motion (+ 1 cm noise), 15 points displaced by
    0.5-3 m at the second site: all outliers go, all inliers stay (weights: inliers agree with >= 59
    others, an outlier with almost none)."""
    rng = np.random.default_rng(5)
    P1 = np.column_stack([rng.uniform(3, 15, 75), rng.uniform(-6, 6, 75), rng.uniform(-1.6, -1.0, 75)])
    T = make_T(rot_z(0.4) @ rot_y(0.05), (-6.0, 1.0, 0.1))
    P2 = P1 @ T[:3, :3].T + T[:3, 3] + rng.normal(0, 0.01, P1.shape)
    out = np.zeros(75, bool)
    out[60:] = True
    dirs = rng.standard_normal((15, 3))
    P2[60:] += dirs / np.linalg.norm(dirs, axis=1, keepdims=True) * rng.uniform(0.5, 3.0, (15, 1))
    keep, w = distance_consistency(P1, P2, np.full(75, 0.01), np.full(75, 0.01), 0.02, 3.0, 0.5)
    assert np.array_equal(keep, ~out)
    assert w[~out].min() >= 59 - 2 and w[out].max() < 30


def test_asift_tilt_set_follows_the_predicted_transition_tilt():
    """Same camera: tilt 1 (no simulated views beyond the first tilt step). A horizontal camera at
    height h maps ground (x forward, y left) to ``u = cx - f y / x``, ``v = cy + f h / x``: the local
    tilt is ``x / h``, so a point 2 m and 12 m ahead of the two cameras has transition tilt 12 / 2."""
    K = np.array([[1189.0, 0, 511.5], [0, 1189.0, 511.5], [0, 0, 1]])
    R = np.array([[0.0, 0, 1], [-1, 0, 0], [0, -1, 0]])      # forward-looking OpenCV camera
    near, far = make_T(R, (8.0, 0, 1.5)), make_T(R, (-2.0, 0, 1.5))
    p = np.array([10.0, 0.0, 0.0])
    tau0, s0 = transition(near, near, K, p)
    assert tau0 == pytest.approx(1.0) and s0 == pytest.approx(1.0)
    tau, s = transition(far, near, K, p)
    assert tau == pytest.approx(6.0, rel=1e-9) and s == pytest.approx(np.sqrt(6.0 ** 3), rel=1e-9)
    assert tilt_set(1.0, 4.0) == [1.0, SQRT2]
    assert tilt_set(tau, 4.0) == pytest.approx([1.0, SQRT2, 2.0, 2 * SQRT2])      # sqrt(6) = 2.45
    assert tilt_set(tau, 2.0) == pytest.approx([1.0, SQRT2, 2.0])
    assert len(view_params(tilt_set(1.0, 4.0))[0]) < len(view_params(tilt_set(tau, 4.0))[0]) / 3


def test_config_names_the_bad_field():
    with pytest.raises(VoError, match=r"crosssite\.mode: unknown 'xx'; valid: ff, fb"):
        CrossSiteConfig(mode="xx")
    with pytest.raises(VoError, match=r"crosssite\.inflate: must be >= 1, got 0\.5"):
        CrossSiteConfig(inflate=0.5)
    with pytest.raises(VoError, match=r"crosssite\.wallis_window_px: must be odd, got 30"):
        CrossSiteConfig(wallis_window_px=30)
    with pytest.raises(VoError, match=r"crosssite\.range_min_m: must be below range_max_m \(20\.0\), got 30\.0"):
        CrossSiteConfig(range_min_m=30.0, range_max_m=20.0)
    with pytest.raises(VoError, match=r"crosssite\.foo: unknown key; valid keys: mode, "):
        CrossSiteConfig.from_dict({"foo": 1})
    assert CrossSiteConfig.from_dict({"ratio": 0.7}).ratio == 0.7


def test_records_reject_bad_input_and_mast_convention():
    from vo.crosssite.types import Site, StereoCal, StereoPair, mast_T_b_c
    K = np.array([[500.0, 0, 99.5], [0, 500.0, 79.5], [0, 0, 1]])
    with pytest.raises(VoError, match="rectified"):
        StereoCal(K, make_T(rot_z(0.01), (0.2, 0, 0)), 200, 160)
    cal = StereoCal(K, make_T(np.eye(3), (0.2, 0, 0)), 200, 160)
    img = np.zeros((160, 200), np.uint8)
    pair = StereoPair(img, img, np.eye(4))
    with pytest.raises(VoError, match="uint8"):
        StereoPair(img.astype(float), img, np.eye(4))
    with pytest.raises(VoError, match="cov_prior"):
        Site(0, 0, [pair], cal, np.eye(4), -np.eye(6))
    # pan +90 deg turns the head's x axis (forward) to body +y (left); tilt rotates about the head's y
    T = mast_T_b_c(make_T(np.eye(3), (0.3, 0, 1.5)), np.pi / 2, 0.0, np.eye(4))
    assert np.allclose(T[:3, 0], [0, 1, 0]) and np.allclose(T[:3, 3], [0.3, 0, 1.5])
    T = mast_T_b_c(np.eye(4), 0.0, 0.3, np.eye(4))
    assert np.allclose(T[:3, :3], rot_y(0.3))


def test_point_margins_propagate_the_prior_per_point():
    """Per-point region margins (§2.1): a body-x translation sigma s moves a point at depth z by
    f s / z pixels (camera x = body x), so near points get wide margins and far ones narrow; a yaw
    sigma about the camera's vertical axis moves a pixel by f (1 + x^2) s_rot at normalized x.
    Checked against the closed forms (first order; the Jacobian is numerical)."""
    from vo.crosssite.regions import point_margins_px, project
    K = np.array([[800.0, 0, 400], [0, 800.0, 300], [0, 0, 1]])
    T_b_c = np.eye(4)                         # camera = body
    P_w = np.array([[0.0, 0, 2.0], [0.0, 0, 10.0], [1.0, 0, 5.0]])
    fn = lambda T: project(T @ T_b_c, K, P_w)[0]  # noqa: E731
    C = np.diag([0, 0, 0, 0.2 ** 2, 0, 0])
    m = point_margins_px(fn, np.eye(4), C, 3.0)
    assert np.allclose(m, 3.0 * 800.0 * 0.2 / P_w[:, 2], rtol=1e-4)
    C = np.diag([0, 0.01 ** 2, 0, 0, 0, 0])   # rotation about camera y
    m = point_margins_px(fn, np.eye(4), C, 1.0)
    x = P_w[:, 0] / P_w[:, 2]
    assert np.allclose(m, 800.0 * (1 + x ** 2) * 0.01, rtol=1e-4)


def test_descriptor_matching_in_chunks_equals_one_pass(monkeypatch):
    """``asift.match`` splits a train set too large for cv2.BFMatcher (2^18 rows) into chunks; the
    result must be that of one pass: the planted near-copies found, each with its own index."""
    from vo.crosssite import asift
    rng = np.random.default_rng(3)
    a = rng.random((300, 128), dtype=np.float32)
    b = rng.random((5000, 128), dtype=np.float32)
    b[1000:1300] = a + 0.01 * rng.standard_normal((300, 128)).astype(np.float32)
    one = asift.match(a, b, 0.8)
    monkeypatch.setattr(asift, "MAX_TRAIN_ROWS", 777)
    chunked = asift.match(a, b, 0.8)
    assert np.array_equal(one, chunked)
    assert len(one) == 300 and np.array_equal(one[:, 1], one[:, 0] + 1000)
