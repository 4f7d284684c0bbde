"""ROP estimator extensions: standstill (rotation-only path), keyframe epochs, vectorised Sampson LM,
grid detection and the four-view KLT tracks, on the ray-cast textured corridor (no MuJoCo)."""
import numpy as np
import pytest

from rigs.presets import get_rig
from vo.dataset.types import StereoFrame
from vo.estimators.synthetic import box_scene, render
from vo.frontend.grid import Grid
from vo.frontend.klt import KltConfig, detect_in_empty_cells
from rigs.geometry import make_T, rot_y, rotation_angle, so3_exp, skew
from vo.rop.estimator import RopEstimator
from vo.rop.griddetect import detect_grid
from vo.rop.relative import chirality, sampson_jacobian
from vo.rop.rotation_only import rotation_only
from vo.rop.tracks import KltFourView

RIG = get_rig("stereo27")                  # 752x480 pinhole, 0.27 m baseline, no distortion


@pytest.fixture(scope="module")
def planes():
    return box_scene(np.random.default_rng(3))


def stereo_frame(planes, k, T_o_c0, rng):
    """Rendered pair at ``T_o_c0`` plus 1 grey level of seeded Gaussian noise (as the renderer adds)."""
    def noisy(img):
        return np.clip(img + rng.normal(0, 1.0, img.shape), 0, 255).astype(np.uint8)
    left = render(planes, RIG.cameras[0], T_o_c0)
    right = render(planes, RIG.cameras[1], T_o_c0 @ RIG.T_c0_c1)
    return StereoFrame(k, k * 50_000_000, noisy(left), noisy(right))


def test_standstill_gives_identity_then_motion_is_solved_against_the_keyframe(planes):
    rng = np.random.default_rng(0)
    poses = [np.eye(4)] * 5 + [make_T(rot_y(np.radians(0.3 * k)), [0.01 * k, 0.0, 0.12 * k]) for k in range(1, 5)]
    est = RopEstimator(RIG)
    res = [est.process(stereo_frame(planes, k, T, rng)) for k, T in enumerate(poses)]
    assert res[0].status == "init"
    for r in res[1:5]:          # standstill: no lost frame, identity motion (Kabsch on noise: < 0.01 deg)
        assert r.status == "ok" and "no translation" in r.message, r.message
        assert np.all(r.T_o_c0[:3, 3] == 0.0)
        assert np.degrees(rotation_angle(r.T_o_c0[:3, :3])) < 0.01
        assert np.all(np.isfinite(r.cov)) and np.all(np.linalg.eigvalsh(r.cov) > 0)
    assert all(r.status in ("ok", "keyframe") for r in res[5:]), [r.message for r in res]
    # 0.48 m of forward motion at 2-8 m depth: ROP steps are good to ~0.3 %; 2 % / 0.1 deg leave margin
    err = np.linalg.norm(res[-1].T_o_c0[:3, 3] - poses[-1][:3, 3])
    assert err < 0.02 * np.linalg.norm(poses[-1][:3, 3])
    assert np.degrees(rotation_angle(res[-1].T_o_c0[:3, :3].T @ poses[-1][:3, :3])) < 0.1


def test_four_view_tracks_share_one_feature_set(planes):
    rng = np.random.default_rng(1)
    fv, timings = KltFourView(RIG), {}
    f0 = stereo_frame(planes, 0, np.eye(4), rng)
    n = fv.keyframe(f0.left, f0.right, timings)
    f1 = stereo_frame(planes, 1, make_T(np.eye(3), [0.0, 0.0, 0.1]), rng)
    v = fv.track(f1.left, f1.right, timings)
    assert n > 150 and len(v) > 0.9 * n and v.ok4.mean() > 0.9
    # the stereo pairs are rectified-like (same rows) within the epipolar tolerance of 1 px
    assert np.max(np.abs(v.p1[:, 1] - v.p2[:, 1])) < 1.0 and np.max(np.abs(v.p3[v.ok4, 1] - v.p4[v.ok4, 1])) < 1.0
    assert {"detect", "track", "stereo"} <= set(timings)


def test_grid_detection_matches_the_per_cell_detector(planes):
    img = render(planes, RIG.cameras[0], np.eye(4))
    grid = Grid(img.shape[1], img.shape[0], 32)
    a = detect_in_empty_cells(img, grid, np.zeros((0, 2)))
    b = detect_grid(img, grid, np.zeros((0, 2)))
    assert np.array_equal(np.sort(grid.cell_index(a)), np.sort(grid.cell_index(b)))   # same cells
    ka, kb = {c: p for c, p in zip(grid.cell_index(a), a)}, {c: p for c, p in zip(grid.cell_index(b), b)}
    same = np.mean([np.allclose(ka[c], kb[c]) for c in ka])
    assert same > 0.8           # ties / non-max suppression differ in a few cells only
    assert len(detect_grid(img, grid, b)) == 0                # every detection cell is now occupied


def test_sampson_jacobian_matches_finite_differences():
    rng = np.random.default_rng(2)
    R, t = so3_exp(rng.normal(0, 0.05, 3)), np.array([0.2, -0.1, 0.97])
    t /= np.linalg.norm(t)
    B = np.linalg.svd(t.reshape(1, 3))[2][1:].T
    x_i, x_j = rng.normal(0, 0.4, (30, 2)), rng.normal(0, 0.4, (30, 2))
    r0, J = sampson_jacobian(R, t, B, x_i, x_j)
    eps = 1e-7
    for k in range(5):
        z = np.zeros(5)
        z[k] = eps
        tz = t + B @ z[3:]
        r1, _ = sampson_jacobian(so3_exp(z[:3]) @ R, tz / np.linalg.norm(tz), B, x_i, x_j)
        np.testing.assert_allclose((r1 - r0) / eps, J[:, k], rtol=1e-4, atol=1e-6)   # O(eps) FD error


def test_rotation_only_fit_and_parallax():
    rng = np.random.default_rng(4)
    p_c1 = np.c_[rng.uniform(-3, 3, (200, 2)), rng.uniform(4, 20, 200)]
    R_1_3 = so3_exp([0.01, -0.02, 0.005])
    for t_1_3, expect_small in ((np.zeros(3), True), (np.array([0.0, 0.0, 0.3]), False)):
        p_c3 = (p_c1 - t_1_3) @ R_1_3                          # p_c3 = R_1_3^T (p_c1 - t_1_3)
        R, parallax, _ = rotation_only(p_c1[:, :2] / p_c1[:, 2:], p_c3[:, :2] / p_c3[:, 2:], 450.0)
        if expect_small:        # exact data: the Kabsch fit is exact
            assert parallax < 1e-6 and np.degrees(rotation_angle(R.T @ R_1_3)) < 1e-6
        else:                   # 0.3 m forward at 4-20 m: median translational flow ~2 px
            assert parallax > 1.0
    # OpenCV convention x_3 = R x_1 + t with R = R_1_3^T, t = -R_1_3^T t_1_3: every point is in front,
    # and the mirrored translation puts them all behind
    x_1, x_3 = p_c1[:, :2] / p_c1[:, 2:], p_c3[:, :2] / p_c3[:, 2:]
    t = -R_1_3.T @ t_1_3
    assert np.all(chirality(R_1_3.T, t, x_1, x_3)) and not np.any(chirality(R_1_3.T, -t, x_1, x_3))
    assert skew([1, 0, 0]).shape == (3, 3)
