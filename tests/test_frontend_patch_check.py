"""ZNCC verification of LK matches (vo.frontend.patch_check): exact values, its noise statistics, and the
stationary noise tracks it removes from the KLT front-ends."""
import cv2
import numpy as np
import pytest

from vo.frontend.klt import KltConfig, track_fb
from vo.frontend.noise_level import estimate_noise_sigma
from vo.frontend.patch_check import NoiseLevel, affine_zncc, weak_texture, zncc, zncc_mask
from vo.rop.tracks import lk_fb
from helpers.stereo_pair import grid_points, shifted, texture


def test_zncc_is_one_at_the_true_shift_and_affine_invariant():
    f0 = texture(1)
    f1 = 0.5 * shifted(f0, 3.3, -1.7) + 40.0            # exact shift, then a gain and an offset
    p0 = grid_points(*f0.shape)
    z = zncc(f0, f1, p0, p0 + [3.3, -1.7], 21)
    # only the bilinear sampling of a blur-2 texture at a sub-pixel position differs: 0.995 bound
    assert z.min() > 0.995, z.min()
    z_off = zncc(f0, f1, p0, p0 + [3.3 + 8, -1.7], 21)  # 8 px off: another part of the texture
    assert np.median(z_off) < 0.5, np.median(z_off)


def test_zncc_of_signal_under_noise_follows_its_snr():
    """A window of signal variance s^2 under independent noise n^2 in each image: E[ZNCC] = s^2 / (s^2 + n^2);
    two independent noise images: mean 0 and spread 1 / win (win^2 nearly independent samples)."""
    rng = np.random.default_rng(7)
    f = texture(2, blur=1.0)
    f = (f - f.mean()) / f.std()                        # unit signal variance
    p = grid_points(*f.shape, step=20, margin=20)
    for n in (0.5, 1.0, 2.0):
        a = f + n * rng.standard_normal(f.shape)
        b = f + n * rng.standard_normal(f.shape)
        z = zncc(a, b, p, p, 21)
        # mean over ~150 windows: the per-window signal variance scatters around 1, tolerance 0.08
        assert abs(z.mean() - 1 / (1 + n ** 2)) < 0.08, (n, z.mean())
    z0 = zncc(rng.standard_normal(f.shape), rng.standard_normal(f.shape), p, p, 21)
    assert abs(z0.mean()) < 4 / 21 / np.sqrt(len(p)) + 0.01, z0.mean()
    assert 0.5 / 21 < z0.std() < 2.0 / 21, z0.std()


def test_zncc_mask_keeps_only_correlated_matches_and_minus_one_is_off():
    f0 = texture(3)
    p0 = grid_points(*f0.shape)
    p1 = p0 + [2.0, 0.0]
    p1[::2] += [15.0, 0.0]                              # every second match is wrong
    f1 = shifted(f0, 2.0, 0.0)
    ok = np.ones(len(p0), bool)
    ok[1] = False
    kept = zncc_mask(f0, f1, p0, p1, ok, 21, 0.5)
    assert not kept[::2].any() and kept[3::2].all() and not kept[1]
    assert (zncc_mask(f0, f1, p0, p1, ok, 21, -1.0) == ok).all()


@pytest.mark.parametrize("tracker", ["klt", "rop", "rop-texture-gate"])
def test_noise_views_give_stationary_tracks_that_the_check_removes(tracker):
    """Two frames of a view without texture (flat grey + independent shot-like noise, sigma 2 grey levels): LK
    on the normalised pyramids returns forward-backward-consistent near-zero motion for some corners - tracks
    that say "nothing moved"; with min_zncc 0.5 none survive. A textured view under the same noise moving
    by 6 px keeps its tracks."""
    rng = np.random.default_rng(11)
    h, w = 240, 320
    noise = lambda: np.clip(np.round(120 + 2.0 * rng.standard_normal((h, w))), 0, 255).astype(np.uint8)
    p0 = grid_points(h, w, step=20, margin=30)
    snr = 2.0 if tracker == "rop-texture-gate" else 0.0       # rop's default: the gate on windows < 2x the noise
    run = (lambda a, b, p, c: track_fb(a, b, p, c)) if tracker == "klt" else \
        (lambda a, b, p, c: lk_fb(a, b, p, c, texture_snr=snr, noise=NoiseLevel()))
    a, b = noise(), noise()
    _, ok_off = run(a, b, p0, KltConfig(min_zncc=-1.0))
    _, ok_on = run(a, b, p0, KltConfig(min_zncc=0.5))
    assert ok_off.sum() >= 5, ok_off.sum()              # the failure the check exists for
    assert ok_on.sum() == 0, ok_on.sum()
    f0 = texture(4)
    t0 = np.clip(np.round(f0 + 2.0 * rng.standard_normal(f0.shape)), 0, 255).astype(np.uint8)
    t1 = np.clip(np.round(shifted(f0, 6.0, 0.0) + 2.0 * rng.standard_normal(f0.shape)), 0, 255).astype(np.uint8)
    p1, ok = run(t0, t1, p0, KltConfig(min_zncc=0.5))
    assert ok.mean() > 0.95, ok.mean()
    assert np.abs(p1[ok] - p0[ok] - [6.0, 0.0]).max() < 0.2


def test_affine_second_chance_keeps_sheared_true_matches_and_still_drops_noise():
    """A view sheared by 0.4 px per row (the ground under a stereo pair: disparity growing down the image)
    decorrelates a translation-only 21 x 21 window of fine texture below ZNCC 0.5 at most true matches; the
    affine fit converges on >= 90 % of them (the others: the warped window leaves the image or the fit leaves
    its basin) and restores them (ZNCC > 0.9 under noise of std 2 on a texture of std ~30), so with ``affine``
    those stay, without it most go. Windows of flat grey under the same noise are dropped either way, and so are
    all but a few matches 6 px off the true one on the sheared view (the fit may move 1 px)."""
    rng = np.random.default_rng(9)
    f0 = texture(6, blur=1.0)
    shear = np.float32([[1.0, 0.4, -48.0], [0.0, 1.0, 0.0]])          # x' = x + 0.4 (y - 120)
    f1 = cv2.warpAffine(f0.astype(np.float32), shear, (f0.shape[1], f0.shape[0]), flags=cv2.INTER_CUBIC,
                        borderMode=cv2.BORDER_REFLECT)
    noisy = lambda f: f + 2.0 * rng.standard_normal(f.shape)
    a, b = noisy(f0), noisy(f1)
    p0 = grid_points(*f0.shape)
    p1 = p0 @ shear[:, :2].T + shear[:, 2]
    ok = np.ones(len(p0), bool)
    assert np.median(zncc(a, b, p0, p1, 21)) < 0.5                      # the geometry the window misses
    z, c, fitted = affine_zncc(a, b, p0, p1, 21)
    assert fitted.mean() >= 0.9 and z[fitted].min() > 0.9 and np.abs(c - p1)[fitted].max() < 0.1
    assert zncc_mask(a, b, p0, p1, ok, 21, 0.5, affine=True).mean() >= 0.9
    assert zncc_mask(a, b, p0, p1, ok, 21, 0.5, affine=False).mean() < 0.5
    # the warp's freedom lifts some wrong matches' ZNCC (1 of 35 here reaches 0.59): fewer than 10 % kept
    assert zncc_mask(a, b, p0, p1 + [6.0, 0.0], ok, 21, 0.5, affine=True).mean() < 0.1
    g0, g1 = noisy(np.full(f0.shape, 120.0)), noisy(np.full(f0.shape, 120.0))
    assert not zncc_mask(g0, g1, p0, p0, ok, 21, 0.5, affine=True).any()


def test_texture_gate_keeps_sheared_true_matches_and_drops_matches_on_noise():
    """``texture_snr`` 2: the gate applies only where the weaker window's std is below twice the image noise.
    On a textured view sheared by 0.4 px per row (true matches, ZNCC mostly < 0.5; texture std ~30 against
    noise 2: 15 times) every true match stays; on two views of flat grey under the same noise (window std =
    the noise, 1x) every match goes, as with the plain gate. Noise from the images themselves (Immerkaer,
    :func:`estimate_noise_sigma`: within 15 % of the true 2.0 on these images)."""
    rng = np.random.default_rng(13)
    f0 = texture(6, blur=1.0)
    shear = np.float32([[1.0, 0.4, -48.0], [0.0, 1.0, 0.0]])
    f1 = cv2.warpAffine(f0.astype(np.float32), shear, (f0.shape[1], f0.shape[0]), flags=cv2.INTER_CUBIC,
                        borderMode=cv2.BORDER_REFLECT)
    noisy = lambda f: np.clip(np.round(f + 2.0 * rng.standard_normal(f.shape)), 0, 255).astype(np.uint8)
    a, b = noisy(f0), noisy(f1)
    p0 = grid_points(*f0.shape)
    p1 = p0 @ shear[:, :2].T + shear[:, 2]
    ok = np.ones(len(p0), bool)
    g0, g1 = noisy(np.full(f0.shape, 120.0)), noisy(np.full(f0.shape, 120.0))
    assert abs(estimate_noise_sigma(g0) - 2.0) < 0.3
    assert zncc_mask(a, b, p0, p1, ok, 21, 0.5).mean() < 0.5                    # the plain gate drops most
    assert zncc_mask(a, b, p0, p1, ok, 21, 0.5, texture_snr=2.0).all()          # the texture gate none
    assert not weak_texture(a, b, p0, p1, 21, 2.0).any()
    assert weak_texture(g0, g1, p0, p0, 21, 2.0).all()
    assert not zncc_mask(g0, g1, p0, p0, ok, 21, 0.5, texture_snr=2.0).any()
    # a wrong match from a textured window onto flat grey: its weaker window is noise, so the gate applies
    h = g1.copy()
    h[:, h.shape[1] // 2:] = a[:, h.shape[1] // 2:]
    left = p0[:, 0] < h.shape[1] // 2 - 15
    assert not zncc_mask(a, h, p0[left], p0[left], ok[left], 21, 0.5, texture_snr=2.0).any()


def test_noise_level_remembers_the_last_images_by_identity():
    """NoiseLevel gives estimate_noise_sigma's value, remembered for its last ``keep`` image objects."""
    rng = np.random.default_rng(3)
    imgs = [np.clip(120 + s * rng.standard_normal((60, 80)), 0, 255).astype(np.uint8) for s in (1.0, 3.0, 5.0, 7.0)]
    nl = NoiseLevel(keep=3)
    first = [nl(im) for im in imgs[:3]]
    assert [nl(im) for im in imgs[:3]] == first and len(nl._seen) == 3
    assert first[0] < first[1] < first[2]
    nl(imgs[3])                                       # the oldest is forgotten, the others kept
    assert [im is imgs[0] for im, _ in nl._seen] == [False] * 3
    assert nl(imgs[1]) == estimate_noise_sigma(imgs[1])
    big = np.clip(np.round(120 + 2.0 * rng.standard_normal((480, 640))), 0, 255).astype(np.uint8)
    assert abs(NoiseLevel()(big) - np.sqrt(4.0 + 1 / 12)) < 0.1              # noise 2 + rounding


def test_zncc_mask_with_texture_gate_is_the_composition_of_zncc_and_weak_texture():
    """``zncc_mask`` computes each window once (the texture gate reuses the ZNCC's windows); exact truth: the
    same mask, match by match, as :func:`zncc` < gate, then :func:`weak_texture` on the failing matches, on an
    8-bit view whose left half is textured and right half flat under noise (matches 0-3 px off)."""
    rng = np.random.default_rng(11)
    f0 = texture(5)
    f0[:, f0.shape[1] // 2:] = 128.0
    img0 = np.clip(np.rint(f0 + rng.normal(0, 2.0, f0.shape)), 0, 255).astype(np.uint8)
    img1 = np.clip(np.rint(shifted(f0, 1.5, 0.0) + rng.normal(0, 2.0, f0.shape)), 0, 255).astype(np.uint8)
    p0 = grid_points(*f0.shape, step=12, margin=15)
    p1 = p0 + [1.5, 0.0] + rng.uniform(-3, 3, p0.shape) * (rng.random((len(p0), 1)) < 0.3)
    ok = rng.random(len(p0)) < 0.9
    for snr in (0.0, 2.0, 6.0):
        got = zncc_mask(img0, img1, p0, p1, ok, 21, 0.5, texture_snr=snr, noise=estimate_noise_sigma)
        bad = ok & (zncc(img0, img1, p0, p1, 21) < 0.5)
        if snr > 0:
            bad[bad] = weak_texture(img0, img1, p0[bad], p1[bad], 21, snr)
        assert 0 < bad.sum() < ok.sum(), snr
        assert (got == (ok & ~bad)).all(), snr
