"""The mid-exposure ground truth of a blurred frame is exact (docs/sensor_effects.md, "Time: what a timestamp means").

Two ``--ideal`` datasets of the same 0.35 s of ``indoor-short`` (cart27, 10 Hz), moving at the 0.8 m/s cruise
speed from the first frame, with the vibration off so that the velocity is nearly constant over an exposure:
one sharp (no exposure), one blurred (80 ms exposure, 9 sub-frames). The written truth and depth are those of
the mid-exposure time in both.

Features found in sharp frame k sit at integer pixels, are lifted with the written depth and the true pose of
frame k (exact: no blur, no noise), and are tracked (pyramidal KLT) into *blurred* frame k+1. A blur that is
symmetric about the mid-exposure projection leaves KLT at that projection, so PnP on these 2-D/3-D
correspondences must return the pose written for frame k+1 to within the noise of the tracks. The pose at the
start of the exposure (40 ms earlier, 3 cm back along the path) must be rejected.

Why the reference is the sharp dataset: lifting features found in the *blurred* frame k with the truth of frame
k cannot tell the conventions apart. Under a wrong convention (start of exposure) both frames' poses are off by
the same amount at constant velocity, the lifted points move with them, and PnP returns the wrong pose with
perfect consistency.
"""
import cv2
import numpy as np
import pytest

from sim.generate import generate, resolve
from sim.scenarios import get_scenario
from vo.dataset.open import open_dataset

from studies import load_study

B = load_study("blur_tracks")

# d^2 of the PnP pose against a pose, in the metric of its covariance sigma^2 (J^T J)^-1: chi^2 with 6 dof for
# white track noise; 5^2 = 25 is its 99.97 % quantile.
D_MAX = 5.0


@pytest.fixture(scope="module")
def datasets(tmp_path_factory):
    root = tmp_path_factory.mktemp("blur_truth")
    out = {}
    for name, extra in (("sharp", []), ("blurred", B.BLUR)):
        generate(get_scenario("indoor-short", B.COMMON + extra), root / name, progress=False)
        out[name] = open_dataset(root / name)
    return out


def test_blurred_dataset_writes_mid_exposure_truth_and_depth(datasets):
    sharp, blurred = datasets["sharp"], datasets["blurred"]
    assert np.array_equal(sharp.frame_times_ns, blurred.frame_times_ns)
    assert np.array_equal(sharp.groundtruth_cam0().T, blurred.groundtruth_cam0().T)
    for k in range(len(blurred)):       # the depth written is the mid-exposure render's, bit for bit
        assert np.array_equal(sharp.depth(k), blurred.depth(k))
    # and the blur is real: the blurred image differs from the sharp one by more than rounding
    assert np.abs(sharp.frame(2).left.astype(float) - blurred.frame(2).left).mean() > 1.0


@pytest.mark.parametrize("k", [1, 2])
def test_pnp_on_blurred_frame_gives_mid_exposure_pose(datasets, k):
    sharp, blurred = datasets["sharp"], datasets["blurred"]
    cam = sharp.rig.cameras[0]
    px, p_w = B.lifted_features(sharp, k)
    q, ok = B.track(sharp.frame(k).left, blurred.frame(k + 1).left, px)
    x_mid = B.rt(blurred.groundtruth_cam0().T[k + 1])
    proj_mid = cv2.projectPoints(p_w, x_mid[:3], x_mid[3:], B.K_matrix(cam), np.asarray(cam.dist))[0].reshape(-1, 2)
    assert ok.sum() > 100

    # the poses a wrong convention would write: the exposure's start and end (the vehicle's true trajectory)
    setup = resolve(get_scenario("indoor-short", B.COMMON + B.BLUR))
    t = int(blurred.frame_times_ns[k + 1]) + np.array([-1, 1]) * int(B.EXPOSURE_MS * 5e5)
    T_w_c_ends = setup.trajectory.states(t).T_w_b @ setup.rig.cameras[0].T_b_c_array
    proj_start = cv2.projectPoints(p_w, *np.split(B.rt(T_w_c_ends[0]), 2), B.K_matrix(cam),
                                   np.asarray(cam.dist))[0].reshape(-1, 2)
    half_blur = np.median(np.linalg.norm(proj_mid - proj_start, axis=1)[ok])
    assert half_blur > 0.8          # blur ~2 px at the median feature (measured 1.9), up to 9 px at the edges

    # KLT lands on the mid-exposure projection: along each feature's image motion, the mean offset of the
    # tracks from it is well under the half blur, while from the start-of-exposure projection it is the half blur
    u = (proj_mid - proj_start)[ok]
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    along_mid = np.mean(np.sum((q - proj_mid)[ok] * u, axis=1))
    along_start = np.mean(np.sum((q - proj_start)[ok] * u, axis=1))
    assert abs(along_mid) < 0.1 * half_blur
    assert along_start > 0.8 * half_blur

    x, info, sigma = B.pnp(p_w[ok], q[ok], cam, x_mid)
    assert sigma < 0.6                              # measured 0.25-0.30 px, as KLT into the sharp frame

    def d(x_ref):                                               # Mahalanobis distance of the PnP pose to x_ref
        e = x - x_ref
        return float(np.sqrt(e @ info @ e))

    assert d(x_mid) < D_MAX
    for T_end in T_w_c_ends:                                    # start and end of the exposure: rejected
        assert d(B.rt(T_end)) > 3 * D_MAX
    # the same in metres: the camera centre is within mm of the truth, the exposure's ends 3 cm away
    err_mid = np.linalg.norm(B.camera_centre(x) - B.camera_centre(x_mid))
    err_start = np.linalg.norm(B.camera_centre(x) - T_w_c_ends[0][:3, 3])
    assert err_start > 5 * err_mid
