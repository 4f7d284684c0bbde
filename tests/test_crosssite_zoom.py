"""The zoom of the previous site's image before matching (seed 001 §2.2), on a synthetic textured
ground plane seen by two forward, 20 deg down-looking cameras 8.5 m apart (the `yutu-traverse`
geometry): the overlap is seen at a scale change of 2-5 and a transition tilt of 1.7-2.8.
Truth is exact: the scene is the plane, so a previous pixel's true match is its image under the
true ground-plane homography."""
import cv2
import numpy as np
import pytest

from helpers.ground_plane import navcam_pose, regolith_texture
from rigs.geometry import inv_T, make_T
from vo.crosssite import asift, zoom
from vo.crosssite.asift import transition

W = H = 512
F = 600.0
K = np.array([[F, 0, (W - 1) / 2], [0, F, (H - 1) / 2], [0, 0, 1.0]])
RES_M = 0.01                       # texture: 1 cm per texel
X0, Y0, NX, NY = -1.0, -12.0, 4200, 2400   # texture covers x in [-1, 41] m, y in [-12, 12] m


def _camera(x_m: float, tilt_rad: float = np.radians(20.0), h_m: float = 1.5) -> np.ndarray:
    return navcam_pose(x_m, 0.0, tilt_rad, h_m)


def _texture(seed: int) -> np.ndarray:
    return regolith_texture(seed, NX, NY, 3000)


def _H_img_tex(T_w_c: np.ndarray) -> np.ndarray:
    """Texel (a, b) -> pixel homography for the ground plane z = 0."""
    T_c_w = inv_T(T_w_c)
    A = np.array([[RES_M, 0, X0], [0, RES_M, Y0], [0, 0, 1.0]])   # texel -> ground (x, y, 1)
    return K @ np.column_stack([T_c_w[:3, 0], T_c_w[:3, 1], T_c_w[:3, 3]]) @ A


def _render(tex: np.ndarray, T_w_c: np.ndarray, ss: int = 3) -> np.ndarray:
    """The plane seen by the camera, supersampled ``ss`` x ``ss`` then area-averaged."""
    S = np.diag([ss, ss, 1.0])
    big = cv2.warpPerspective(tex, S @ _H_img_tex(T_w_c), (W * ss, H * ss), flags=cv2.INTER_LINEAR)
    return cv2.resize(big, (W, H), interpolation=cv2.INTER_AREA)


def _true_H(T_w_c_prev, T_w_c_cur) -> np.ndarray:
    return _H_img_tex(T_w_c_cur) @ np.linalg.inv(_H_img_tex(T_w_c_prev))


def _match(img_p, img_c, M=None) -> tuple:
    """(previous pixels, current pixels) of SIFT matches; with ``M`` the previous image is zoomed
    into the current geometry first and its points mapped back."""
    src = img_p
    mask = np.full((H, W), 255, np.uint8)
    if M is not None:
        src, mask = zoom.warp_image(img_p, M, W, H)
    uv_a, d_a = asift.detect(src, mask, [1.0], 0, asift=False, contrast=0.01)
    uv_b, d_b = asift.detect(img_c, np.full((H, W), 255, np.uint8), [1.0], 0, asift=False, contrast=0.01)
    ab = asift.match(d_a, d_b, 0.8)
    uv_a = uv_a[ab[:, 0]]
    return (zoom.unwarp_points(uv_a, M) if M is not None else uv_a), uv_b[ab[:, 1]]


def _n_true(uv_p, uv_c, H_true, tol_px=2.0) -> int:
    if len(uv_p) == 0:
        return 0
    pred = cv2.perspectiveTransform(uv_p.reshape(1, -1, 2).astype(np.float64), H_true)[0]
    return int((np.linalg.norm(pred - uv_c, axis=1) <= tol_px).sum())


@pytest.fixture(scope="module")
def views():
    tex = _texture(7)
    T_p, T_c = _camera(0.0), _camera(8.5)
    return tex, T_p, T_c, _render(tex, T_p), _render(tex, T_c)


def test_geometry_is_the_traverse_case(views):
    """The centre of the current view (4.1 m ahead) is seen from the previous site at 12.6 m: the
    ground's local map between the views stretches 2.9x across range (the distance ratio) and about
    8x along it (times the ratio of the grazing angles), i.e. scale sqrt(2.9 * 8) ~ 4.8 and
    transition tilt 8 / 2.9 ~ 2.8."""
    _, T_p, T_c, _, _ = views
    tau, s = transition(T_p, T_c, K, np.array([8.5 + 1.5 / np.tan(np.radians(20)), 0, 0]))
    assert 4.3 < s < 5.2 and 2.5 < tau < 3.1


def test_zoom_finds_true_ties_where_plain_sift_does_not(views):
    """Plain SIFT across the scale 4.7 / tilt 2.8 change finds almost no true ties; the ground-plane
    zoom predicted from a prior 0.6 m short and 2 deg off in heading finds many, and every point is
    mapped back to the original previous image (truth: the exact plane homography, 2 px)."""
    tex, T_p, T_c, img_p, img_c = views
    H_true = _true_H(T_p, T_c)
    uv_p, uv_c = _match(img_p, img_c)
    n_plain = _n_true(uv_p, uv_c, H_true)
    a = np.radians(2.0)
    T_c_prior = make_T(np.array([[np.cos(a), -np.sin(a), 0], [np.sin(a), np.cos(a), 0], [0, 0, 1]]), [-0.6, 0.1, 0]) @ T_c
    M = zoom.plane_homography(T_p, T_c_prior, np.eye(4), K, W, H, 40.0)
    uv_p, uv_c = _match(img_p, img_c, M)
    n_zoom = _n_true(uv_p, uv_c, H_true)
    assert n_plain < 10 and n_zoom > 40, (n_plain, n_zoom)
    assert n_zoom > 0.3 * len(uv_p), (n_zoom, len(uv_p))


def test_scale_zoom_maps_points_back_exactly():
    """The paper's scale zoom is a similarity about the box centres; unwarping inverts it."""
    M = zoom.scale_warp((100, 50, 300, 150), (0, 0, 512, 512), 3.7)
    c = zoom.unwarp_points(np.array([[256.0, 256.0]]), M)[0]
    assert np.allclose(c, [200.0, 100.0])
    uv = np.random.default_rng(0).uniform(0, 500, (20, 2))
    fwd = cv2.perspectiveTransform(uv.reshape(1, -1, 2), M)[0]
    assert np.allclose(zoom.unwarp_points(fwd, M), uv, atol=1e-9)
    assert np.allclose(fwd - fwd.mean(0), 3.7 * (uv - uv.mean(0)))
