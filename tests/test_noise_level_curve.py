"""Noise level per brightness (vo.frontend.noise_level.noise_level_curve / fit_shot_read_noise) against
the shot + read noise model of sim.sensors.photometric with known parameters, and the `realistic`
preset against a real EuRoC frame (tests/data/EUROC_EXCERPT.md)."""
from pathlib import Path

import cv2
import numpy as np
import pytest

from sim.sensors.effects_presets import REALISTIC_CAMERA
from sim.sensors.photometric import noise_variance, sensor_noise
from vo.errors import VoError
from vo.frontend.noise_level import fit_shot_read_noise, noise_level_curve

EUROC_FRAME = Path(__file__).parent / "data" / "euroc_v1_01_easy_cam0_1403715276262142976.png"


def _model_sigma(levels, read_dn, gain):
    return np.sqrt(noise_variance(levels, read_dn, gain) + 1.0 / 12.0)


def test_curve_and_fit_recover_shot_and_read_noise_on_a_ramp():
    """A linear ramp (which Immerkaer's kernel cancels exactly) through the sensor model with K = 0.03,
    r = 0.8: each bin within 6 % of the model (about 30 000 pixels per bin, 20 % of them used: the
    estimate's relative std is ~1 %), the fitted K within 10 % and r within 0.3 grey levels."""
    ramp = np.tile(np.linspace(8.0, 247.0, 752), (480, 1))
    img = sensor_noise(ramp, 0.8, 0.03, np.random.default_rng(7))
    levels, sigmas, counts = noise_level_curve(img)
    assert levels.size >= 12 and counts.min() >= 2000
    ratio = sigmas / _model_sigma(levels, 0.8, 0.03)
    assert np.all(np.abs(ratio - 1) < 0.06), ratio
    gain, read = fit_shot_read_noise(levels, sigmas)
    assert abs(gain / 0.03 - 1) < 0.10 and abs(read - 0.8) < 0.3, (gain, read)


def test_curve_leaves_out_clipped_pixels():
    """A ramp saturating over its right third: the clipped pixels have no noise and are not counted."""
    ramp = np.tile(np.linspace(60.0, 400.0, 600), (300, 1))
    img = sensor_noise(ramp, 0.5, 0.03, np.random.default_rng(1))
    levels, sigmas, counts = noise_level_curve(img, min_pixels=500)
    assert levels.max() < 256 and counts.sum() < (img < 250).sum()
    assert np.all(np.abs(sigmas / _model_sigma(levels, 0.5, 0.03) - 1) < 0.08)


def test_curve_on_rendered_frames_with_the_preset_noise(campus_depth_ideal):
    """Noise-free rendered campus frames through the preset's sensor noise: per bin of level >= 56 with
    >= 2000 pixels, within [0.93, 1.15] of the model (measured 0.98-1.11: texture that is not locally
    quadratic adds to the estimate). Below 56 the campus pixels are shadowed foliage whose texture
    outweighs the low noise there (1.5-1.8x the model), which is why the preset is fitted on real frames."""
    from vo.dataset import open_dataset
    ds = open_dataset(campus_depth_ideal)
    rng = np.random.default_rng(5)
    for k in (5, 30):
        img = ds.frame(k).left
        img = img if img.ndim == 2 else cv2.cvtColor(img, cv2.COLOR_RGB2GRAY)
        noisy = sensor_noise(img, REALISTIC_CAMERA.read_noise_dn, REALISTIC_CAMERA.shot_noise_gain, rng)
        levels, sigmas, _ = noise_level_curve(noisy, bin_edges=np.arange(48, 257, 16))
        ratio = sigmas / _model_sigma(levels, REALISTIC_CAMERA.read_noise_dn, REALISTIC_CAMERA.shot_noise_gain)
        assert levels.size >= 5 and np.all((ratio > 0.93) & (ratio < 1.15)), (k, levels, ratio)


def test_realistic_preset_matches_a_real_euroc_frame():
    """The preset's noise model against the noise curve of a real EuRoC V1_01 cam0 frame: median
    deviation over the brightness bins within 10 %, every bin within 25 % (the preset is a two-parameter
    fit to 190 frames of both cameras, docs/sensor_effects.md; the real curve bends below the linear
    variance model at the dark end)."""
    img = cv2.imread(str(EUROC_FRAME), cv2.IMREAD_GRAYSCALE)
    levels, sigmas, _ = noise_level_curve(img)
    assert levels.size >= 8
    ratio = _model_sigma(levels, REALISTIC_CAMERA.read_noise_dn, REALISTIC_CAMERA.shot_noise_gain) / sigmas
    assert np.median(np.abs(ratio - 1)) < 0.10 and np.all(np.abs(ratio - 1) < 0.25), (levels, ratio)


def test_fit_rejects_bad_input():
    with pytest.raises(VoError, match="fit_shot_read_noise"):
        fit_shot_read_noise([10.0], [1.0])
    with pytest.raises(VoError, match="shape"):
        noise_level_curve(np.zeros((2, 9)))
