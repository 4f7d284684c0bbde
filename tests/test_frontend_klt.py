"""LK accuracy, forward-backward rejection, epipolar check, illumination-invariant LK."""
import cv2
import numpy as np

from vo.frontend.correspondences import correspondences
from vo.frontend.klt import KltConfig, KltTracker, lk, track_fb
from vo.frontend.lk_invariant import lk_illumination_invariant
from vo.frontend.stereo import epipolar_mask, triangulate
from helpers.stereo_pair import grid_points, shifted, stereo_rig, texture

def test_lk_recovers_subpixel_translation():
    f0 = texture(1)
    f1 = shifted(f0, 0.37, -0.61)
    img0, img1 = np.round(f0).astype(np.uint8), np.round(f1).astype(np.uint8)
    p0 = grid_points(*img0.shape)
    p1, ok = track_fb(img0, img1, p0, KltConfig())
    assert ok.all()
    err = np.linalg.norm(p1 - (p0 + [0.37, -0.61]), axis=1)
    # only uint8 quantisation (+-0.5 grey level on a ~200-level texture) perturbs the images: 0.05 px bound
    assert err.max() < 0.05, err.max()


def test_forward_backward_rejects_changed_region():
    f0 = texture(2)
    f1 = shifted(f0, 2.0, 1.0)
    f1[:, 160:] = texture(3)[:, 160:]          # the right half changes completely between frames
    img0, img1 = np.round(f0).astype(np.uint8), np.round(f1).astype(np.uint8)
    p0 = grid_points(*img0.shape)
    left = p0[:, 0] + 10 + 2 < 160              # whole 21x21 window stays in the unchanged half
    right = p0[:, 0] - 10 > 160
    p1, ok = track_fb(img0, img1, p0, KltConfig())
    assert ok[left].all()
    assert np.abs(p1[left] - p0[left] - [2, 1]).max() < 0.05
    # new random content: LK converges somewhere but the round trip does not come back within 1 px
    assert ok[right].mean() < 0.3, ok[right].mean()


def test_epipolar_check_rejects_off_line_point():
    rig = stereo_rig()          # rectified, baseline 0.2 m along +x of c0: epipolar lines are rows
    p_l = np.array([[100.0, 80.0], [200.0, 150.0], [150.0, 120.0]])
    p_r = p_l - [[30.0, 0.0], [12.0, 0.0], [20.0, 0.0]]
    p_r[2, 1] += 1.5            # 1.5 px off its epipolar line (> 1 px threshold)
    assert epipolar_mask(rig, p_l, p_r, 1.0).tolist() == [True, True, False]
    p_c0, ok = triangulate(rig, p_l[:2], p_r[:2])
    assert ok.all()
    assert np.allclose(p_c0[:, 2], 300 * 0.2 / np.array([30.0, 12.0]), rtol=1e-9)   # Z = f b / d


def test_triangulation_rejects_negative_and_far():
    rig = stereo_rig()
    p_l = np.array([[100.0, 80.0], [100.0, 80.0]])
    p_r = p_l + [[5.0, 0.0], [-0.5, 0.0]]      # negative disparity -> behind; 0.5 px -> 120 m > 80 m
    _, ok = triangulate(rig, p_l, p_r, max_depth=80.0)
    assert not ok.any()


def test_illumination_invariant_lk_beats_plain_lk_under_gain():
    f0 = texture(4, lo=40, hi=160)
    f1 = 1.5 * shifted(f0, 1.3, -0.8)           # gain 1.5 (max 240, no saturation)
    img0, img1 = np.round(f0).astype(np.uint8), np.round(f1).astype(np.uint8)
    p0 = grid_points(*img0.shape)
    truth = p0 + [1.3, -0.8]
    p_inv, ok_inv = lk_illumination_invariant(img0, img1, p0, win=21, levels=4)
    p_cv, ok_cv = lk(img0, img1, p0, KltConfig(normalize_box=0))       # brightness constancy, raw images
    p_n, ok_n = lk(img0, img1, p0, KltConfig())                        # default: normalised pyramids
    e_inv = np.linalg.norm(p_inv - truth, axis=1)
    e_cv = np.where(ok_cv, np.linalg.norm(p_cv - truth, axis=1), np.inf)
    e_n = np.linalg.norm(p_n - truth, axis=1)
    assert ok_inv.all() and ok_n.all()
    # the local-mean-normalised pyramids are gain invariant as well (a constant gain cancels in I / mean(I))
    assert e_n.max() < 0.05, e_n.max()
    # the normalised residual is exactly gain invariant: only quantisation remains (0.05 px);
    # plain LK's brightness-constancy residual is biased by the gain change
    assert e_inv.max() < 0.05, e_inv.max()
    assert np.median(e_cv) > 3 * np.median(e_inv), (np.median(e_cv), np.median(e_inv))


def test_tracker_keeps_ids_and_correspondences():
    f0 = texture(5)
    img0 = np.round(f0).astype(np.uint8)
    img1 = np.round(shifted(f0, -1.5, 0.5)).astype(np.uint8)
    tr = KltTracker(320, 240, KltConfig())
    ids = tr.detect(img0)
    assert len(ids) == 8 * 6               # one per interior cell of the 10 x 8 grid (last row partial)
    before = dict(zip(tr.ids.tolist(), tr.pts.copy()))
    tr.track(img1)
    assert len(tr.ids) > 0.9 * len(ids)
    for i, p in zip(tr.ids.tolist(), tr.pts):
        assert np.linalg.norm(p - before[i] - [-1.5, 0.5]) < 0.05
    p_a, p_b = correspondences(img0, img1, "klt")
    assert len(p_a) > 30 and np.abs(p_b - p_a - [-1.5, 0.5]).max() < 0.05


def test_tracker_append_restores_tracks_set_aside_after_the_new_ones():
    """keep() a subset, detect() into the cells the others held, append() them back: the set-aside tracks come
    back unchanged (ids and pixels) after the kept ones and the new corners, and no id is reused."""
    img = np.round(texture(5)).astype(np.uint8)
    tr = KltTracker(320, 240, KltConfig())
    tr.detect(img)
    pts, ids = tr.pts.copy(), tr.ids.copy()
    aside = np.arange(len(ids)) % 2 == 1
    tr.keep(~aside)
    new = tr.detect(img)
    assert len(new) == aside.sum() and not np.isin(new, ids).any()
    tr.append(pts[aside], ids[aside])
    np.testing.assert_array_equal(tr.ids, np.concatenate([ids[~aside], new, ids[aside]]))
    np.testing.assert_array_equal(tr.pts[-aside.sum():], pts[aside])
    assert tr.pts.shape == (len(tr.ids), 2) and tr.pts.dtype == np.float64 and tr.ids.dtype == np.int64


def test_klt_config_from_option_takes_a_mapping_and_names_bad_fields():
    import pytest
    from vo.errors import VoError
    assert KltConfig.from_option(None) == KltConfig()
    cfg = KltConfig(win=11)
    assert KltConfig.from_option(cfg) is cfg
    assert KltConfig.from_option({"win": 11, "levels": 3}) == KltConfig(win=11, levels=3)
    with pytest.raises(VoError, match=r"rop.klt_config: unknown field\(s\) \['wn'\]; valid: cell, .*win"):
        KltConfig.from_option({"wn": 11}, "rop.klt_config")
    with pytest.raises(VoError, match="rop.klt_config: 11; expected a mapping"):
        KltConfig.from_option(11, "rop.klt_config")
    with pytest.raises(VoError, match="KltConfig.win: invalid value 10"):
        KltConfig.from_option({"win": 10})
    with pytest.raises(VoError, match="KltConfig.zncc_affine: invalid value 3"):     # a switch takes true/false only
        KltConfig.from_option({"zncc_affine": 3})
    assert KltConfig.from_option({"zncc_affine": True}).zncc_affine is True


def test_estimators_take_klt_config_as_a_mapping_and_name_themselves_in_errors():
    """``--opt 'klt_config={win: 11}'`` reaches each KLT-using estimator; a bad field names the estimator."""
    import pytest
    from rigs.presets import get_rig
    from vo.errors import VoError
    from vo.estimators.registry import make_estimator
    rig = get_rig("cart27")
    assert make_estimator("rop", rig, klt_config={"win": 11}).klt.config.win == 11
    for name in ("klt-pnp", "orb-pnp"):
        assert make_estimator(name, rig, klt_config={"win": 11}).klt_config.win == 11
        with pytest.raises(VoError, match=rf"^{name}.klt_config: unknown field"):
            make_estimator(name, rig, klt_config={"wn": 11})
