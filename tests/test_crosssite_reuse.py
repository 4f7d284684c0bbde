"""Work shared between the SIFT pass and the ASIFT fallback of one site pair
(:class:`vo.crosssite.asift.DetectionCache`) and the threaded per-region-pair matching: both must give
exactly the features, nearest neighbours and candidate ties of the plain computation, in the same
order. Scene: a synthetic textured ground plane seen by two sites 8.5 m apart with two
20 deg down-looking pointings each (the `yutu-traverse` geometry, tests/helpers/ground_plane.py);
the truth of a candidate tie is the exact ground-plane homography between its two cameras."""
import dataclasses

import cv2
import numpy as np
import pytest

from helpers.ground_plane import navcam_pose, regolith_texture
from rigs.geometry import inv_T, make_T
from vo.crosssite import asift
from vo.crosssite.localizer_config import CrossSiteConfig
from vo.crosssite.ties import candidate_ties
from vo.crosssite.types import Site, StereoCal, StereoPair

W = H = 512
F = 600.0
K = np.array([[F, 0, (W - 1) / 2], [0, F, (H - 1) / 2], [0, 0, 1.0]])
RES_M, X0, Y0 = 0.01, -1.0, -12.0          # texture: 1 cm per texel from (x, y) = (-1, -12) m
PANS_DEG = (-12.0, 12.0)
COV = np.diag([0.01 ** 2] * 3 + [0.2 ** 2] * 3)


def _H_img_tex(T_w_c: np.ndarray) -> np.ndarray:
    T_c_w = inv_T(T_w_c)
    A = np.array([[RES_M, 0, X0], [0, RES_M, Y0], [0, 0, 1.0]])
    return K @ np.column_stack([T_c_w[:3, 0], T_c_w[:3, 1], T_c_w[:3, 3]]) @ A


def _render(tex: np.ndarray, T_w_c: np.ndarray, ss: int = 2) -> np.ndarray:
    big = cv2.warpPerspective(tex, np.diag([ss, ss, 1.0]) @ _H_img_tex(T_w_c), (W * ss, H * ss), flags=cv2.INTER_LINEAR)
    return cv2.resize(big, (W, H), interpolation=cv2.INTER_AREA)


def _site(index: int, tex, x_m: float) -> Site:
    T_w_b = make_T(np.eye(3), [x_m, 0.0, 0.0])
    pairs = []
    for pan in np.radians(PANS_DEG):
        T_b_c0 = navcam_pose(0.0, pan)
        img = _render(tex, T_w_b @ T_b_c0)
        pairs.append(StereoPair(img, img, T_b_c0, float(pan)))
    cal = StereoCal(K, make_T(np.eye(3), [0.3, 0, 0]), W, H)
    return Site(index, index, pairs, cal, T_w_b, COV)


@pytest.fixture(scope="module")
def sites():
    tex = regolith_texture(11, 4200, 2400, 3000)
    return _site(0, tex, 0.0), _site(1, tex, 8.5)


def _n_true(prev: Site, cur: Site, ties, tol_px: float = 2.0) -> int:
    n = 0
    for k in range(len(ties.pair_prev)):
        i, j = ties.pair_prev[k], ties.pair_cur[k]
        Hm = _H_img_tex(cur.T_w_b_prior @ cur.pairs[j].T_b_c0) @ np.linalg.inv(
            _H_img_tex(prev.T_w_b_prior @ prev.pairs[i].T_b_c0))
        pred = cv2.perspectiveTransform(ties.uv_prev[k].reshape(1, 1, 2), Hm)[0, 0]
        n += np.linalg.norm(pred - ties.uv_cur[k]) <= tol_px
    return int(n)


def test_asift_on_a_cached_sift_view_equals_one_affine_feature_call(sites):
    """ASIFT's tilt-1 view is plain SIFT: taking it from the cache and appending the other views
    gives cv2.AffineFeature's features and descriptors exactly, in its order."""
    img = sites[0].pairs[0].left
    mask = np.zeros((H, W), np.uint8)
    mask[H // 3:, 40:W - 40] = 255
    tilts = [1.0, asift.SQRT2]
    det = cv2.AffineFeature.create(cv2.SIFT_create(nfeatures=0, contrastThreshold=0.01))
    det.setViewParams(*asift.view_params(tilts))
    kps, desc = det.detectAndCompute(img, mask)
    cache = asift.DetectionCache()
    sift = asift.detect(img, mask, tilts, 0, asift=False, contrast=0.01, cache=cache)
    uv, d = asift.detect(img, mask, tilts, 0, asift=True, contrast=0.01, cache=cache)
    assert cache.hits == 1 and 0 < len(sift[0]) < len(uv)
    assert np.array_equal(uv, np.array([k.pt for k in kps])) and np.array_equal(d, desc)
    other = mask.copy()
    other[:, :W // 2] = 0      # a different mask is a different key: no stale features
    uv2, _ = asift.detect(img, other, tilts, 0, asift=False, contrast=0.01, cache=cache)
    assert cache.hits == 1 and len(uv2) < len(sift[0])


def test_cached_nearest_neighbours_equal_one_pass():
    """Rows already matched against the same train set come from the cache; the matches of the
    extended query equal those without a cache (planted near-copies found, each at its index)."""
    rng = np.random.default_rng(5)
    b = rng.random((3000, 128), dtype=np.float32)
    a = b[rng.permutation(3000)[:400]] + 0.01 * rng.standard_normal((400, 128)).astype(np.float32)
    a_more = np.vstack([a, rng.random((300, 128), dtype=np.float32)])
    cache = asift.DetectionCache()
    first = asift.match(a, b, 0.8, cache)
    both = asift.match(a_more, b, 0.8, cache)
    assert cache.hits == 1
    assert np.array_equal(first, asift.match(a, b, 0.8)) and np.array_equal(both, asift.match(a_more, b, 0.8))
    assert len(first) == 400
    b2 = b.copy()
    b2[0] += 1.0               # another train set: computed afresh
    asift.match(a_more, b2, 0.8, cache)
    assert cache.hits == 1


def test_asift_pass_after_sift_pass_and_threads_give_the_same_ties(sites):
    """The ASIFT fallback run on the SIFT pass's cache and on two threads finds exactly the
    candidates of a fresh single-thread run, in the same order, and they hold true ties."""
    prev, cur = sites
    cfg = CrossSiteConfig(asift_fallback_ties=20, workers=1)
    fresh = candidate_ties(prev, prev.T_w_b_prior, cur, cfg)
    cache = asift.DetectionCache()
    candidate_ties(prev, prev.T_w_b_prior, cur, dataclasses.replace(cfg, use_asift=False, workers=2), cache)
    hits_sift = cache.hits
    reused = candidate_ties(prev, prev.T_w_b_prior, cur, dataclasses.replace(cfg, workers=2), cache)
    n_zoomed = fresh.stats["n_zoomed_pairs"]
    assert n_zoomed >= 2 and hits_sift == 0
    # every current image's features and every zoomed pair's SIFT view and nearest neighbours reused
    assert cache.hits == len(cur.pairs) + 2 * n_zoomed
    for f in ("pair_prev", "uv_prev", "pair_cur", "uv_cur"):
        assert np.array_equal(getattr(fresh, f), getattr(reused, f)), f
    assert fresh.stats == reused.stats
    assert _n_true(prev, cur, fresh) >= 30, _n_true(prev, cur, fresh)


def test_gemm_nearest_neighbours_equal_bfmatcher_on_byte_valued_descriptors(monkeypatch):
    """SIFT descriptors are integers 0-255: the matrix-product distances are exact, so neighbours,
    distances and the order of equal distances (duplicate train rows) are cv2.BFMatcher's, in blocks
    of any size and with a one-row train set; non-integer descriptors go to cv2.BFMatcher."""
    rng = np.random.default_rng(9)
    b = rng.integers(0, 256, (2000, 128)).astype(np.float32)
    b[1500:1600] = b[200:300]                      # duplicate rows: equal distances
    a = np.clip(b[rng.integers(0, 2000, 600)] + rng.integers(-3, 4, (600, 128)), 0, 255).astype(np.float32)
    monkeypatch.setattr(asift, "GEMM_BLOCK", 2000 * 37)
    for train in (b, b[:1]):
        exact = asift._two_nearest_gemm(a, train)
        bf = asift._two_nearest_bf(a, train)
        assert all(np.array_equal(x, y) for x, y in zip(exact, bf))
    assert asift._byte_valued(a) and not asift._byte_valued(a + 0.5) and not asift._byte_valued(a - 1.0)
