"""Stereo PnP estimators on an exactly rendered synthetic corridor with known camera motion."""
import numpy as np
import pytest

from rigs.model import Camera, Rig
from rigs.records import StereoFrame
from vo.errors import EstimatorError
from vo.estimators.base import MAX_COAST_FRAMES, frame_class
from vo.estimators.orb_pnp import OrbPnpEstimator
from vo.estimators.pnp import KltPnpEstimator
from vo.estimators.pnp_core import PnpConfig
from helpers.synthetic import box_scene, render
from rigs.geometry import inv_T, make_T, rot_y, rotation_angle

R_B_C = np.array([[0, 0, 1], [-1, 0, 0], [0, -1, 0]])
N_FRAMES = 8


def make_rig():
    cams = tuple(Camera(n, 640, 480, 500, 500, 319.5, 239.5, T_b_c=make_T(R_B_C, [0, y, 1.0]))
                 for n, y in (("cam0", 0.15), ("cam1", -0.15)))
    return Rig("synthetic", cams)


def true_pose(k):
    """T_o_c0 at frame k: 8 cm forward, 1 cm right and 0.3 deg yaw per frame."""
    return make_T(rot_y(np.radians(0.3 * k)), [0.01 * k, 0.0, 0.08 * k])


def stereo_frame(rig, planes, k, blank=None):
    T = true_pose(k)
    if blank is not None:
        img = np.full((480, 640), blank, np.uint8)
        return StereoFrame(k, k * 50_000_000, img, img.copy())
    return StereoFrame(k, k * 50_000_000, render(planes, rig.cameras[0], T),
                       render(planes, rig.cameras[1], T @ rig.T_c0_c1))


@pytest.fixture(scope="module")
def sequence():
    rig = make_rig()
    planes = box_scene(np.random.default_rng(7))
    return rig, [stereo_frame(rig, planes, k) for k in range(N_FRAMES)]


def relative_errors(results, ks):
    """Per-frame relative-motion error (m, deg) between estimated and true T_{c(k-1)}_{c(k)}."""
    out = []
    for k in ks:
        est = inv_T(results[k - 1].T_o_c0) @ results[k].T_o_c0
        tru = inv_T(true_pose(k - 1)) @ true_pose(k)
        d = inv_T(est) @ tru
        out.append((np.linalg.norm(d[:3, 3]), np.degrees(rotation_angle(d[:3, :3]))))
    return np.array(out)


@pytest.mark.parametrize("make, max_m, max_deg", [
    # noise-free renders, KLT / SIFT sub-pixel (~0.05 px) localisation: a few mm per 8 cm step
    (lambda rig: KltPnpEstimator(rig), 0.01, 0.1),
    (lambda rig: OrbPnpEstimator(rig, frontend="sift"), 0.01, 0.1),
    # ORB key points are found on a 1.2-scale pyramid with integer-pixel positions per level: ~0.5-1 px noise
    (lambda rig: OrbPnpEstimator(rig), 0.06, 0.5),
])
def test_relative_motion_recovered(sequence, make, max_m, max_deg):
    rig, frames = sequence
    est = make(rig)
    results = [est.process(f) for f in frames]
    assert results[0].status == "init" and np.allclose(results[0].T_o_c0, np.eye(4))
    assert all(r.status in ("ok", "keyframe") for r in results[1:]), [r.status for r in results]
    assert [frame_class(r) for r in results] == ["ok"] * N_FRAMES      # the first frame's pose is the origin
    err = relative_errors(results, range(1, N_FRAMES))
    assert err[:, 0].max() < max_m, err
    assert err[:, 1].max() < max_deg, err
    for r in results:
        assert set(r.timings_ms) >= {"detect", "track", "stereo", "pnp", "total"}
        assert r.timings_ms["total"] >= r.timings_ms["pnp"]


def test_klt_pnp_inlier_count_and_keyframes(sequence):
    rig, frames = sequence
    est = KltPnpEstimator(rig)
    results = [est.process(f) for f in frames]
    # 18 x 13 interior cells of the 20 x 15 grid give at most 234 first-frame corners
    assert 100 <= results[0].n_features <= 234
    assert all(r.n_inliers <= r.n_features for r in results)


@pytest.mark.parametrize("cls", [KltPnpEstimator, OrbPnpEstimator])
def test_blank_frames_few_features_then_reinit(sequence, cls):
    rig, frames = sequence
    planes = box_scene(np.random.default_rng(7))
    seq = list(frames[:4]) + [stereo_frame(rig, planes, 4, blank=255), stereo_frame(rig, planes, 5, blank=0)] \
        + [stereo_frame(rig, planes, k) for k in (6, 7, 8)]
    est = cls(rig)
    results = [est.process(f) for f in seq]
    statuses = [r.status for r in results]
    assert statuses[4] == "few_features" and statuses[5] == "few_features", statuses
    assert "tracked <" in results[4].message or "landmarks <" in results[4].message
    assert statuses[6] == "reinit", statuses
    # 4 and 5 failed, 6 re-initialised at the pose extrapolated from 3 at constant velocity: coasted poses
    assert [frame_class(r) for r in results] == ["ok"] * 4 + ["coasting"] * 3 + ["ok"] * 2
    # the coasted step: the last step's rotation, the median translation of the measured steps 1-3
    steps = [inv_T(results[k - 1].T_o_c0) @ results[k].T_o_c0 for k in (1, 2, 3)]
    step = make_T(steps[-1][:3, :3], np.median([s[:3, 3] for s in steps], axis=0))
    assert np.allclose(results[6].T_o_c0, results[3].T_o_c0 @ step @ step @ step)
    assert all(np.all(np.isfinite(r.T_o_c0)) for r in results)
    # after re-initialisation the relative motion is right again (same bounds as above, ORB's looser)
    err = relative_errors(results, [7, 8])
    assert err[:, 0].max() < (0.01 if cls is KltPnpEstimator else 0.06), err


def test_all_black_sequence_never_initialises():
    rig = make_rig()
    est = KltPnpEstimator(rig)
    for k in range(3):
        r = est.process(stereo_frame(rig, None, k, blank=0))
        assert r.status == "few_features" and np.array_equal(r.T_o_c0, np.eye(4))
        assert frame_class(r) == "init"                  # a placeholder: no pose yet


def test_coasting_ends_in_held_poses():
    """After MAX_COAST_FRAMES failed frames the pose is held: those frames are lost, not coasting."""
    rig = make_rig()
    planes = box_scene(np.random.default_rng(7))
    est = KltPnpEstimator(rig)
    good = [est.process(stereo_frame(rig, planes, k)) for k in range(3)]
    failed = [est.process(stereo_frame(rig, planes, 3 + k, blank=0)) for k in range(MAX_COAST_FRAMES + 2)]
    assert [frame_class(r) for r in good] == ["ok"] * 3
    assert [frame_class(r) for r in failed] == ["coasting"] * MAX_COAST_FRAMES + ["lost"] * 2
    assert np.array_equal(failed[-1].T_o_c0, failed[-3].T_o_c0)


def test_options_validated():
    rig = make_rig()
    with pytest.raises(EstimatorError, match="valid: orb, sift"):
        OrbPnpEstimator(rig, frontend="klt")
    with pytest.raises(EstimatorError, match="valid: klt"):
        KltPnpEstimator(rig, frontend="orb")
    with pytest.raises(EstimatorError, match=r"pnp\.method: unknown 'p3p-magic'; valid: iterative, epnp"):
        PnpConfig(method="p3p-magic")
    with pytest.raises(EstimatorError, match=r"pnp\.min_pnp_inliers: must be >= 4, got 3"):
        PnpConfig(min_pnp_inliers=3)
    mono = Rig("mono", (rig.cameras[0],))
    with pytest.raises(EstimatorError, match="stereo"):
        KltPnpEstimator(mono)


def test_coasted_frames_turn_by_the_rotation_of_their_tracks():
    """A turn that speeds up (pure rotation, yaw steps 0.4, 0.6, ... deg) with every PnP refused (min_features
    above any track count): each coasted step takes the rotation-only fit of the frame-to-frame tracks
    (exact for a pure rotation: noise-free renders, ~0.05 px KLT localisation -> < 0.05 deg), where constant
    velocity would repeat the previous step and lag by the 0.2-deg increment on every frame."""
    rig = make_rig()
    planes = box_scene(np.random.default_rng(7))
    yaw = lambda k: np.radians(0.3 * k + 0.1 * k * k)                     # noqa: E731
    frames = [StereoFrame(k, k * 50_000_000, render(planes, rig.cameras[0], make_T(rot_y(yaw(k)), np.zeros(3))),
                          render(planes, rig.cameras[1], make_T(rot_y(yaw(k)), np.zeros(3)) @ rig.T_c0_c1))
              for k in range(6)]
    est = KltPnpEstimator(rig, pnp_config=PnpConfig(min_features=100_000))
    results = [est.process(f) for f in frames]
    assert results[0].status == "init"
    assert [frame_class(r) for r in results[1:]] == ["coasting"] * 5
    for k in range(1, 6):
        step = inv_T(results[k - 1].T_o_c0) @ results[k].T_o_c0
        err = np.degrees(rotation_angle(step[:3, :3].T @ rot_y(yaw(k) - yaw(k - 1))))
        assert err < 0.05, (k, err)


def test_coasted_frames_keep_the_steady_velocity_not_a_last_odd_step():
    """Constant true motion (8 cm forward, 1 cm right, 0.3 deg yaw per frame) except one step that moves 6 cm
    sideways more (as a PnP fitted on a few landmarks bunched on one wall can trade yaw for sideways
    translation), then blank frames: the coasted steps take the median translation of the last five measured
    steps, the steady one (PnP on noise-free renders: within 1 cm, as above), where repeating the last step
    would put the 6 cm into every coasted step."""
    rig = make_rig()
    planes = box_scene(np.random.default_rng(7))
    jolt = make_T(np.eye(3), [0.06, 0.0, 0.0])
    pose = lambda k: true_pose(k) @ (jolt if k >= 6 else np.eye(4))                        # noqa: E731
    frames = [StereoFrame(k, k * 50_000_000, render(planes, rig.cameras[0], pose(k)),
                          render(planes, rig.cameras[1], pose(k) @ rig.T_c0_c1)) for k in range(7)]
    frames += [stereo_frame(rig, planes, k, blank=0) for k in (7, 8, 9)]
    est = KltPnpEstimator(rig)
    results = [est.process(f) for f in frames]
    assert [frame_class(r) for r in results] == ["ok"] * 7 + ["coasting"] * 3
    jolted = inv_T(results[5].T_o_c0) @ results[6].T_o_c0
    assert np.linalg.norm(jolted[:3, 3] - (inv_T(pose(5)) @ pose(6))[:3, 3]) < 0.01      # the odd step measured
    for k in (7, 8, 9):
        step = inv_T(results[k - 1].T_o_c0) @ results[k].T_o_c0
        true = inv_T(true_pose(k - 1)) @ true_pose(k)
        assert np.linalg.norm(step[:3, 3] - true[:3, 3]) < 0.01, (k, step[:3, 3], true[:3, 3])
