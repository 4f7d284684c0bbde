"""Re-noising propagation (vo.errorprop.renoise) and the image-noise reader it uses (rigs.image_noise).

The toy estimator's pose is linear in the image noise, so its run-to-run covariance is known in
closed form: position x = s * (mean grey level of the left image - 128). A noisy image is
``rint(I + sigma n)``; for a smooth random texture the rounding error is close to uniform and
independent of ``n``, so each pixel's variance is ``sigma^2 + 1/12`` and the mean of P pixels has
variance ``(sigma^2 + 1/12) / P``.
"""
import numpy as np
import pytest

from sim.app.nees import NoisyDataset
from rigs.image_noise import MC_TAG, ImageNoiseDataset
from rigs.records import StereoFrame
from rigs.errors import TestbedError
from vo.errors import VoError
from vo.errorprop.renoise import renoise_covariance
from vo.estimators.base import Estimator, FrameResult
from helpers.synthetic import random_texture
from rigs.geometry import make_T

from test_estimators_pnp import make_rig  # noqa: E402  (tests/ is on sys.path under pytest's rootdir)

SCALE = 0.01     # m per grey level of the mean
H, W = 24, 32


class MeanGreyEstimator(Estimator):
    """x = SCALE * (mean grey of the left image - 128); identity rotation."""

    name = "mean-grey"

    def process(self, frame):
        x = SCALE * (float(np.mean(frame.left)) - 128.0)
        return FrameResult(frame.t_ns, make_T(np.eye(3), [x, 0.0, 0.0]), "ok")


class TexturedDataset:
    """Smooth random textures (grey 20-235: no clipping at the noise levels used), one per frame."""

    def __init__(self, n=4, seed=7):
        rng = np.random.default_rng(seed)
        self.rig, self.imu, self.path = make_rig(), None, None
        self._imgs = [random_texture(rng, W, H, blur_texels=3.0) for _ in range(n)]

    def __len__(self):
        return len(self._imgs)

    def frame(self, k):
        return StereoFrame(k, 1000 * k, self._imgs[k], self._imgs[k][::-1].copy())

    def frames(self, start=0, stop=None, step=1):
        for k in range(start, len(self) if stop is None else stop, step):
            yield self.frame(k)


def test_image_noise_is_seeded_per_frame_and_key():
    base = TexturedDataset()
    a, b = ImageNoiseDataset(base, 1.0, 5), ImageNoiseDataset(base, 1.0, 5)
    assert np.array_equal(a.frame(2).left, b.frame(2).left)
    assert np.array_equal([f.left for f in a.frames()][2], a.frame(2).left)      # order does not matter
    assert not np.array_equal(a.frame(2).left, ImageNoiseDataset(base, 1.0, 6).frame(2).left)
    assert not np.array_equal(a.frame(2).left, ImageNoiseDataset(base, 1.0, 5, tag=1).frame(2).left)
    assert np.array_equal(ImageNoiseDataset(base, 0.0, 5).frame(1).left, base.frame(1).left)
    d = a.frame(1).left.astype(float) - base.frame(1).left
    assert 0.9 < d.std() < 1.15                   # sqrt(1 + 1/12) = 1.04


def test_monte_carlo_runs_keep_their_bytes():
    """sim.app.nees.NoisyDataset is the image-noise reader with the runs' stream: the documented
    draw ``default_rng([seed, frame index, 0xC0FFEE])``, unchanged by the move to vo/."""
    base = TexturedDataset()
    f = base.frame(3)
    rng = np.random.default_rng([1004, 3, MC_TAG])
    want = np.clip(np.rint(f.left + 1.0 * rng.standard_normal(f.left.shape)), 0, 255).astype(np.uint8)
    assert np.array_equal(NoisyDataset(base, 1.0, 1004).frame(3).left, want)


def test_image_noise_rejects_bad_sigma():
    with pytest.raises(TestbedError, match="sigma"):
        ImageNoiseDataset(TexturedDataset(), -1.0, 0)
    with pytest.raises(TestbedError, match="sigma"):
        ImageNoiseDataset(TexturedDataset(), float("nan"), 0)


def test_renoise_covariance_of_a_linear_estimator():
    """200 replicates: the position variance is chi-square with 199 dof around the truth
    (sigma^2 + 1/12) SCALE^2 / P; 99.9 % bounds of s^2/var are [0.72, 1.33]. Rotation and y, z: zero."""
    base = TexturedDataset()
    sigma, R = 1.5, 200
    res = renoise_covariance(base, "test_errorprop_renoise:MeanGreyEstimator", replicates=R, sigma=sigma, seed=3)
    want = (sigma ** 2 + 1.0 / 12.0) * SCALE ** 2 / (H * W)
    ratio = res.cov[:, 3, 3] / want
    assert res.cov.shape == (4, 6, 6) and res.sigma == sigma
    assert np.all((ratio > 0.72) & (ratio < 1.33)), ratio
    assert np.allclose(res.cov[:, :3, :3], 0.0) and np.allclose(res.cov[:, 4:, 4:], 0.0)
    again = renoise_covariance(base, "test_errorprop_renoise:MeanGreyEstimator", replicates=R, sigma=sigma, seed=3)
    assert np.array_equal(again.cov, res.cov)                                   # same seed, same bytes


def test_renoise_estimates_the_noise_level_when_not_given():
    base = ImageNoiseDataset(TexturedDataset(), 2.0, 11)          # a "recording" with noise 2
    res = renoise_covariance(base, "test_errorprop_renoise:MeanGreyEstimator", replicates=3, seed=0)
    assert 1.6 < res.sigma < 2.6


def test_replicate_cov_about_the_mean():
    T_hat = np.tile(np.eye(4), (2, 1, 1))
    T_reps = np.tile(np.eye(4), (3, 2, 1, 1))
    T_reps[:, :, 2, 3] = np.array([1.0, 2.0, 3.0])[:, None] + 10.0              # offset: the mean is removed
    from rigs.geometry import pose_error_cov
    C = pose_error_cov(T_reps, T_hat)
    assert C.shape == (2, 6, 6) and np.allclose(C[:, 5, 5], 1.0) and np.allclose(C[:, :5, :5], 0.0)


def test_renoise_rejects_external_commands():
    """An external command would read the clean dataset folder, not the re-noised images."""
    with pytest.raises(VoError, match="external commands"):
        renoise_covariance(TexturedDataset(), "cmd:my_vo {dataset} {out}", replicates=3, sigma=1.0)


def test_renoise_rejects_too_few_replicates():
    with pytest.raises(VoError, match="replicates"):
        renoise_covariance(TexturedDataset(), "test_errorprop_renoise:MeanGreyEstimator", replicates=2, sigma=1.0)


def test_renoise_runs_rop_on_a_rendered_recording(campus_depth_ideal):
    """The campus recording with noise 1 (plus rounding: 1.04): the noise level is read back from the
    images, and after the cart has moved the replicates spread in position (rop re-solves every frame)."""
    from vo.dataset import open_dataset
    rec = ImageNoiseDataset(open_dataset(campus_depth_ideal), 1.0, 42)
    res = renoise_covariance(rec, "rop", {"klt_config": {"win": 11}}, replicates=3, seed=1, max_frames=25)
    assert 0.95 < res.sigma < 1.15
    assert res.cov.shape == (25, 6, 6) and np.all(np.isfinite(res.cov))
    assert np.trace(res.cov[-1, 3:, 3:]) > 0 and np.allclose(res.cov[0], 0.0)


def test_consistency_rejects_bad_renoise():
    from sim.errors import SimError
    from sim.app.nees import consistency
    with pytest.raises(SimError, match="renoise: 2; must be 0"):
        consistency("smoke", "rop", runs=2, renoise=2)
    with pytest.raises(SimError, match="renoise"):
        consistency("smoke", "rop", runs=2, renoise=3, oracle_px=0.2)


def test_predict_renoise_cli(campus_depth_ideal, tmp_path):
    """`vo-testbed predict renoise` on a noise-free recording with --sigma given: JSON figures and a plot."""
    import json
    from click.testing import CliRunner
    from sim.app.cli import cli
    png = tmp_path / "rn.png"
    r = CliRunner().invoke(cli, ["predict", "renoise", "--dataset", str(campus_depth_ideal), "--replicates", "3",
                                 "--sigma", "1", "--max-frames", "12", "--opt", "klt_config={win: 11}",
                                 "--plot", str(png), "--json"])
    assert r.exit_code == 0, r.output
    out = json.loads(r.output)
    assert out["replicates"] == 3 and out["n_frames"] == 12 and out["sigma"] == 1.0
    assert np.isfinite(out["end_position_std_m"]) and out["end_position_std_m"] >= 0 and png.stat().st_size > 0
