"""ROP estimator extensions: standstill (rotation-only path), keyframe epochs, vectorised Sampson LM,
grid detection and the four-view KLT tracks, on the ray-cast textured corridor (no MuJoCo)."""
import cv2
import numpy as np
import pytest

from rigs.presets import get_rig
from rigs.records import StereoFrame
from helpers.synthetic import box_scene, render
from vo.frontend.grid import Grid
from vo.frontend.klt import KltConfig, detect_in_empty_cells
from rigs.geometry import make_T, rot_y, rotation_angle, so3_exp, skew
from vo.rop.estimator import RopEstimator
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


def _per_cell_reference(img, grid, config, peaks_only):
    """Reference for :func:`detect_in_empty_cells`, one cell at a time: ``goodFeaturesToTrack`` on the
    cell (with a ``block_size`` margin so the score uses true neighbours; seed 003's rule), or the
    cell's maximum ``cornerMinEigenVal`` score wherever it is (``peaks_only=False``)."""
    out, m = [], config.block_size
    h, w = img.shape
    eig_full = cv2.cornerMinEigenVal(img, m)
    for k in grid.detection_cells(np.zeros((0, 2))):
        x0, y0, x1, y1 = grid.cell_rect(k)
        if not peaks_only:
            cell = eig_full[y0:y1, x0:x1]
            v, u = np.unravel_index(np.argmax(cell), cell.shape)
            if cell[v, u] >= config.min_eigenvalue:
                out.append((u + x0, v + y0))
            continue
        sx0, sy0, sx1, sy1 = max(x0 - m, 0), max(y0 - m, 0), min(x1 + m, w), min(y1 + m, h)
        sub = np.ascontiguousarray(img[sy0:sy1, sx0:sx1])
        mask = np.zeros(sub.shape, np.uint8)
        mask[y0 - sy0:y1 - sy0, x0 - sx0:x1 - sx0] = 255
        c = cv2.goodFeaturesToTrack(sub, maxCorners=1, qualityLevel=config.quality_level,
                                    minDistance=config.min_distance, mask=mask, blockSize=m)
        if c is not None:
            u, v = c.reshape(2)
            if cv2.cornerMinEigenVal(sub, m)[int(round(v)), int(round(u))] >= config.min_eigenvalue:
                out.append((u + sx0, v + sy0))
    return np.array(out, dtype=np.float64).reshape(-1, 2)


@pytest.mark.parametrize("peaks_only", [True, False])
def test_grid_detection_matches_the_per_cell_detector(planes, peaks_only):
    """The vectorised detector (one score image, per-cell maxima) gives exactly the corners of the
    per-cell reference, in cell order; the two rules differ in some cells (a cell maximum on the
    cell edge below a higher neighbour); detected cells are then occupied."""
    img = np.clip(render(planes, RIG.cameras[0], np.eye(4)) + np.random.default_rng(4).normal(0, 1, (480, 752)),
                  0, 255).astype(np.uint8)
    grid, cfg = Grid(img.shape[1], img.shape[0], 32), KltConfig()
    got = detect_in_empty_cells(img, grid, np.zeros((0, 2)), cfg, peaks_only=peaks_only)
    np.testing.assert_array_equal(got, _per_cell_reference(img, grid, cfg, peaks_only))
    other = detect_in_empty_cells(img, grid, np.zeros((0, 2)), cfg, peaks_only=not peaks_only)
    assert len(got) > 100 and not np.array_equal(got, other)
    assert len(detect_in_empty_cells(img, grid, got, cfg, peaks_only=peaks_only)) == 0


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
