"""Orthorectified matching (seed 001 §2.1-2.2, forward-backward) on a synthetic textured ground plane:
the previous site's camera looks forward (+x) and the current site's backward camera looks back
(-x), 180 deg apart, both 1.5 m high and 20 deg down (the `yutu-traverse` Navcam). Truth is exact:
the scene is the plane, so a previous pixel's true match is its image under the true plane homography."""
import cv2
import numpy as np
import pytest

from helpers.ground_plane import navcam_pose, regolith_texture
from rigs.geometry import inv_T, make_T
from vo.crosssite import asift, ortho
from vo.crosssite.localizer_config import CrossSiteConfig

W = H = 512
F = 600.0
K = np.array([[F, 0, (W - 1) / 2], [0, F, (H - 1) / 2], [0, 0, 1.0]])
RES_M = 0.01                                   # texture: 1 cm per texel
X0, Y0, NX, NY = -8.0, -8.0, 3600, 1600        # texture covers x in [-8, 28] m, y in [-8, 8] m
RANGE_M = 20.0                                 # ground beyond this (and the sky) renders black
LEG_M = 8.5                                    # previous -> current site (the traverse legs)


def _camera(x_m: float, yaw_rad: float, tilt_rad: float = np.radians(20.0), h_m: float = 1.5) -> np.ndarray:
    return navcam_pose(x_m, yaw_rad, tilt_rad, h_m)


def _texture(seed: int) -> np.ndarray:
    return regolith_texture(seed, NX, NY, 2000)


def _H_img_tex(T_w_c: np.ndarray) -> np.ndarray:
    """Texel (a, b) -> pixel homography for the ground plane z = 0."""
    A = np.array([[RES_M, 0, X0], [0, RES_M, Y0], [0, 0, 1.0]])
    return ortho.ground_homography(T_w_c, K, np.eye(4)) @ A


def _render(tex: np.ndarray, T_w_c: np.ndarray, ss: int = 3) -> np.ndarray:
    """The plane seen by the camera (supersampled ``ss`` x ``ss``); rays that miss the ground within
    ``RANGE_M`` (sky, far terrain) are black."""
    S = np.diag([ss, ss, 1.0])
    big = cv2.warpPerspective(tex, S @ _H_img_tex(T_w_c), (W * ss, H * ss), flags=cv2.INTER_LINEAR)
    img = cv2.resize(big, (W, H), interpolation=cv2.INTER_AREA)
    u, v = np.meshgrid(np.arange(W), np.arange(H))
    d_w = T_w_c[:3, :3] @ np.linalg.solve(K, np.vstack([u.ravel(), v.ravel(), np.ones(u.size)]))
    with np.errstate(divide="ignore"):
        lam = -T_w_c[2, 3] / d_w[2]
    hit = (d_w[2] < 0) & (lam * np.linalg.norm(d_w, axis=0) <= RANGE_M)
    img[~hit.reshape(H, W)] = 0
    return img


def _n_true(uv_p, uv_c, T_p, T_c, tol_px=2.0) -> int:
    if len(uv_p) == 0:
        return 0
    H_true = _H_img_tex(T_c) @ np.linalg.inv(_H_img_tex(T_p))
    pred = cv2.perspectiveTransform(uv_p.reshape(1, -1, 2).astype(np.float64), H_true)[0]
    return int((np.linalg.norm(pred - uv_c, axis=1) <= tol_px).sum())


@pytest.fixture(scope="module")
def views():
    tex = _texture(11)
    T_p, T_c = _camera(0.0, 0.0), _camera(LEG_M, np.pi)
    return T_p, T_c, _render(tex, T_p), _render(tex, T_c)


def _prior(T_w_c: np.ndarray) -> tuple:
    """The current camera and body frame (the ground plane's frame) at a prior 0.5 m short, 0.2 m
    aside and 2 deg off in heading: the dead reckoning's error."""
    a = np.radians(2.0)
    dT = make_T(np.array([[np.cos(a), -np.sin(a), 0], [np.sin(a), np.cos(a), 0], [0, 0, 1]]), [0.5, 0.2, 0])
    T_w_b = dT @ make_T(np.eye(3), [LEG_M, 0, 0])
    return dT @ T_w_c, T_w_b


def test_grid_maps_ground_points_to_both_images(views):
    """A ground point's grid pixel, pushed through each image's inverse warp, lands on its true
    projection (with the exact pose)."""
    T_p, T_c, _, _ = views
    box = (0, 0, W, H)
    T_w_b = make_T(np.eye(3), [LEG_M, 0, 0])
    grid = ortho.overlap_grid(T_p, T_c, K, box, box, T_w_b, RANGE_M)
    assert grid is not None and max(grid.size) <= 1500
    xy_b = np.array([[-7.0, 0.5], [-5.0, -1.0], [-9.0, 1.5]])           # current body frame
    cr = (xy_b - [grid.x0, grid.y1]) / [grid.gsd_m, -grid.gsd_m]
    for T in (T_p, T_c):
        uv = cv2.perspectiveTransform(cr.reshape(1, -1, 2), np.linalg.inv(ortho.image_to_grid(T, K, grid)))[0]
        P_w = np.c_[xy_b + [LEG_M, 0], np.zeros(3)]
        P_c = (inv_T(T) @ np.c_[P_w, np.ones(3)].T)[:3]
        assert np.allclose(uv, (K @ P_c)[:2].T / P_c[2][:, None], atol=1e-6)


def test_ortho_finds_true_ties_where_plain_sift_does_not(views):
    """Plain SIFT between the forward and the backward view (a 180 deg turn plus the two ranges'
    foreshortening) finds few true ties; orthorectified matching from a prior 0.5 m and 2 deg off
    finds many more, mapped back to original pixels of both images (truth: the plane homography, 2 px)."""
    T_p, T_c, img_p, img_c = views
    full = np.full((H, W), 255, np.uint8)
    uv_a, d_a = asift.detect(img_p, full, [1.0], 0, asift=False, contrast=0.01)
    uv_b, d_b = asift.detect(img_c, full, [1.0], 0, asift=False, contrast=0.01)
    ab = asift.match(d_a, d_b, 0.8)
    n_plain = _n_true(uv_a[ab[:, 0]], uv_b[ab[:, 1]], T_p, T_c)
    T_c_prior, T_w_b_prior = _prior(T_c)
    cfg = CrossSiteConfig(mode="fb", zoom="ortho", use_asift=False, region_max_range_m=RANGE_M)
    uv_p, uv_c, _, _ = ortho.pair_matches(img_p, T_p, img_c, T_c_prior, K, (0, 0, W, H), (0, 0, W, H),
                                          T_w_b_prior, [1.0], cfg)
    n_ortho = _n_true(uv_p, uv_c, T_p, T_c)
    assert n_ortho > max(40, 3 * n_plain), (n_plain, n_ortho)
    assert n_ortho > 0.5 * len(uv_p), (n_ortho, len(uv_p))
