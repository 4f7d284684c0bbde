"""Affine LK refinement (vo.frontend.affine_lk) on exact analytic images.

The images are sampled from one analytic texture, so the true correspondence of every point is
known exactly: an affine image warp, and a textured ground plane seen by a camera moving forward (a
homography), where translation-only LK is biased by the window-averaged flow.
"""
import cv2
import numpy as np

from vo.frontend.affine_lk import affine_template, bilinear, refine_affine
from vo.frontend.klt import KltConfig, lk


def _texture(rng, n=24, min_wavelength=6.0, max_wavelength=40.0):
    """Random sum of ``n`` plane waves f(x, y) (x, y in the texture's own units), values ~0..255."""
    lam = rng.uniform(min_wavelength, max_wavelength, n)
    ang = rng.uniform(0, np.pi, n)
    k = 2 * np.pi / lam[:, None] * np.c_[np.cos(ang), np.sin(ang)]
    phase, amp = rng.uniform(0, 2 * np.pi, n), rng.uniform(0.5, 1.0, n)

    def f(x, y):
        s = sum(a * np.cos(kx * x + ky * y + ph) for (kx, ky), ph, a in zip(k, phase, amp))
        return 128 + 100 * s / amp.sum() * 2.5
    return f


def _image(f, h, w, xy_of_pixel):
    """(h,w) float image: f at the texture coordinates of each pixel, averaged over 3x3 sub-pixels."""
    acc = np.zeros((h, w))
    v, u = np.mgrid[0:h, 0:w].astype(np.float64)
    for du in (-1 / 3, 0, 1 / 3):
        for dv in (-1 / 3, 0, 1 / 3):
            acc += f(*xy_of_pixel(u + du, v + dv))
    return np.clip(acc / 9.0, 0, 255)


def test_bilinear_is_exact_on_linear_images():
    v, u = np.mgrid[0:20, 0:30].astype(np.float64)
    img = 3.0 * u - 2.0 * v + 7.0
    xy = np.random.default_rng(0).uniform([0, 0], [29, 19], (100, 2))
    np.testing.assert_allclose(bilinear(img, xy), 3.0 * xy[:, 0] - 2.0 * xy[:, 1] + 7.0, atol=1e-10)


def test_affine_warp_is_recovered():
    """img1(M p + t) = img0(p) with a 4 % scale change and shear: the refinement, started 0.4 px off
    with A = 0, lands within 0.03 px max / 0.01 px rms of the truth (measured 0.017 / 0.007) and
    recovers the linear part to 6e-3 (measured 4e-3). The floor is bilinear interpolation of img1 at
    fractional positions: with an integer shift and M = I the same code is exact to 1e-6 px."""
    rng = np.random.default_rng(3)
    f = _texture(rng)
    M, t = np.array([[1.04, 0.02], [-0.015, 1.03]]), np.array([3.3, -2.1])
    Mi = np.linalg.inv(M)
    img0 = _image(f, 240, 320, lambda u, v: (u, v))
    img1 = _image(f, 240, 320, lambda u, v: tuple(np.tensordot(Mi, np.stack([u - t[0], v - t[1]]), 1)))
    p0 = np.stack(np.meshgrid(np.arange(40, 281, 30.0), np.arange(40, 201, 30.0)), -1).reshape(-1, 2)
    truth = p0 @ M.T + t
    p1, A, ok = refine_affine(img0, img1, p0, truth + [0.3, -0.25], win=21)
    assert ok.all()
    err = p1 - truth
    assert np.abs(err).max() < 0.03 and np.sqrt(np.mean(err ** 2)) < 0.01, err
    np.testing.assert_allclose(A, np.broadcast_to(M - np.eye(2), A.shape), atol=6e-3)


def _ground_texture(rng, texel_m=0.004, n=1024, blur_texels=2.5, centre=(2.0, 0.0)):
    """Non-periodic random texture on the ground: blurred noise on an ``n`` x ``n`` grid of
    ``texel_m`` texels centred at ``centre`` (x, y metres), evaluated by cubic interpolation."""
    from scipy.ndimage import map_coordinates
    tex = cv2.GaussianBlur(rng.random((n, n)), (0, 0), blur_texels)
    tex = 20 + 215 * (tex - tex.min()) / (tex.max() - tex.min())

    def f(x, y):
        i = (np.asarray(x) - centre[0]) / texel_m + n / 2
        j = (np.asarray(y) - centre[1]) / texel_m + n / 2
        return map_coordinates(tex, [i.ravel(), j.ravel()], order=3, mode="reflect").reshape(np.shape(x))
    return f


def _ground_frames(rng, forward_m=0.05):
    """Camera 1.2 m above a textured ground plane, pitched 25 deg down, moving ``forward_m`` forward.

    Returns (img0, img1, to_img1) with ``to_img1(p0)`` the exact position in img1 of pixel p0."""
    h, w, fpx = 360, 480, 400.0
    K = np.array([[fpx, 0, (w - 1) / 2], [0, fpx, (h - 1) / 2], [0, 0, 1]])
    pitch = np.radians(25)
    # world: x forward, y left, z up; camera: x right, y down, z forward (pitched down)
    R_w_c = np.array([[0, -np.sin(pitch), np.cos(pitch)], [-1, 0, 0], [0, -np.cos(pitch), -np.sin(pitch)]])
    f = _ground_texture(rng)

    def ground(u, v, x_cam):
        ray = np.tensordot(R_w_c, np.stack([(u - K[0, 2]) / fpx, (v - K[1, 2]) / fpx, np.ones_like(u)]), 1)
        s = -1.2 / np.where(ray[2] < -1e-6, ray[2], -1e-6)
        return x_cam + s * ray[0], s * ray[1]

    img0 = _image(f, h, w, lambda u, v: ground(u, v, 0.0))
    img1 = _image(f, h, w, lambda u, v: ground(u, v, forward_m))

    def to_img1(p):
        X, Y = ground(p[:, 0], p[:, 1], 0.0)
        P_c = (np.c_[X - forward_m, Y, np.full(len(X), -1.2)]) @ R_w_c        # R_c_w (p_w - t_w_c)
        return (P_c[:, :2] / P_c[:, 2:]) * fpx + K[:2, 2]
    return img0, img1, to_img1


def test_ground_plane_translation_lk_is_biased_and_affine_is_not():
    """5 cm forward over perspective ground (flow ~4-10 px on the lower image): OpenCV's translation
    LK (21 px window) under-estimates the flow on average, because the flow varies across its window
    and the far, compressed part of the window carries more gradient energy; the affine refinement
    removes most of the bias and 90 % of the scatter. Measured over ~620 corners (fixed seed): error
    along the flow, translation mean -0.0155 px (standard error 0.003), rms 0.072 px; affine mean
    +0.0030 px (s.e. 0.0003; the residual is bilinear interpolation and the window's non-affine
    perspective), rms 0.008 px. Bounds: translation mean < -0.008, affine |mean| < 0.006 and rms < 0.02."""
    img0, img1, to_img1 = _ground_frames(np.random.default_rng(7))
    g0, g1 = np.round(img0).astype(np.uint8), np.round(img1).astype(np.uint8)
    p0 = cv2.goodFeaturesToTrack(g0, 2000, 0.01, 6, blockSize=3).reshape(-1, 2).astype(np.float64)
    p0 = p0[(p0[:, 1] > 200) & (p0[:, 1] < 330) & (p0[:, 0] > 30) & (p0[:, 0] < 450)]
    truth = to_img1(p0)
    flow = truth - p0
    along = flow / np.linalg.norm(flow, axis=1, keepdims=True)
    p_lk, ok_lk = lk(g0, g1, p0, KltConfig())
    p_aff, _, ok_aff = refine_affine(g0, g1, p0, p_lk, win=21)
    ok = ok_lk & ok_aff
    assert ok.sum() > 500, ok.sum()
    e_lk = np.sum((p_lk - truth) * along, axis=1)[ok]
    e_aff = np.sum((p_aff - truth) * along, axis=1)[ok]
    assert e_lk.mean() < -0.008, e_lk.mean()
    assert abs(e_aff.mean()) < 0.006, e_aff.mean()
    assert np.sqrt(np.mean(e_aff ** 2)) < 0.02, np.sqrt(np.mean(e_aff ** 2))


def test_untrackable_points_are_flagged():
    rng = np.random.default_rng(1)
    img = _image(_texture(rng), 120, 160, lambda u, v: (u, v))
    flat = np.full((120, 160), 100.0)
    p0 = np.array([[80.0, 60.0], [5.0, 60.0], [80.0, 115.0]])      # inside, window off the left, off the bottom
    _, _, ok = refine_affine(img, img, p0, p0, win=21)
    assert ok.tolist() == [True, False, False]
    _, _, ok = refine_affine(flat, flat, p0[:1], p0[:1], win=21)   # no texture: singular normal matrix
    assert not ok.any()
    p1, A, ok = refine_affine(img, img, np.zeros((0, 2)), np.zeros((0, 2)))
    assert p1.shape == (0, 2) and A.shape == (0, 2, 2) and ok.shape == (0,)


def test_template_concat_and_replaced_round_trip():
    """concat then subset gives back each part; replaced swaps exactly the given rows."""
    rng = np.random.default_rng(3)
    img = (rng.random((60, 80)) * 255).astype(np.uint8)
    a = affine_template(img, np.array([[20.0, 20.0], [40.0, 30.0]]), 11)
    b = affine_template(img, np.array([[50.0, 25.0]]), 11)
    ab = a.concat(b)
    assert len(ab) == 3 and np.array_equal(ab.subset([2]).T, b.T) and np.array_equal(ab.subset([0, 1]).Jt, a.Jt)
    r = ab.replaced(np.array([0]), b)
    assert np.array_equal(r.p0[0], b.p0[0]) and np.array_equal(r.Hinv[1:], ab.Hinv[1:])
    assert np.array_equal(ab.p0[0], a.p0[0])                       # the original is unchanged
