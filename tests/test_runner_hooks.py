"""The one frame loop (vo.estimators.runner.run_estimator) and the collaborators estimators take through their
constructors: the hooks see every frame, a hook can end the run, studies get PnP data and ROP step inputs
without touching an estimator's internals, and the oracle-tracks validation injects its tracker."""
import numpy as np
import pytest

from vo.estimators.runner import run_estimator
from vo.estimators.sensor_dataset import SensorDataset

from test_estimators_pnp import make_rig  # noqa: E402  (tests/ is on sys.path under pytest's rootdir)
from test_estimators_registry import FakeDataset, NanEstimator  # noqa: E402

SPEC = "test_estimators_registry:StepEstimator"


def test_hooks_receive_every_frame_in_order():
    ds, seen_before, seen_after = FakeDataset(make_rig(), 7), [], []
    res = run_estimator(SPEC, ds, progress=False, before_frame=lambda f: seen_before.append(f.index),
                        on_frame=lambda f, r, est: seen_after.append((f.index, r, est)))
    assert seen_before == list(range(7)) and [k for k, _, _ in seen_after] == list(range(7))
    assert [r for _, r, _ in seen_after] == res.frames            # the checked results, the same objects
    assert all(est is res.estimator for _, _, est in seen_after)
    assert res.estimator.k == 7                                  # the estimator saw each frame once


def test_hook_sees_the_guarded_result_and_can_stop():
    seen = []
    res = run_estimator("test_estimators_registry:NanEstimator", FakeDataset(make_rig(), 5), progress=False,
                        on_frame=lambda f, r, est: seen.append(r.status) or f.index == 2)
    assert seen == ["lost"] * 3 and len(res.frames) == 3 and len(res.trajectory) == 3    # the guard ran first
    assert np.all(np.isfinite(res.trajectory.T))


def test_max_frames_bounds_the_hooks():
    seen = []
    run_estimator(SPEC, FakeDataset(make_rig(), 9), progress=False, max_frames=4,
                  before_frame=lambda f: seen.append(f.index))
    assert seen == [0, 1, 2, 3]


class Probe(NanEstimator):
    """A plug-in that records what ``set_dataset`` received."""

    got: list = []

    def set_dataset(self, dataset):
        Probe.got.append(dataset)


def test_with_truth_hands_the_dataset_itself():
    ds = FakeDataset(make_rig(), 2)
    run_estimator("test_runner_hooks:Probe", ds, progress=False)
    run_estimator("test_runner_hooks:Probe", ds, progress=False, with_truth=True)
    assert isinstance(Probe.got[-2], SensorDataset) and Probe.got[-1] is ds


@pytest.mark.slow
def test_pnp_observer_gets_pixels_and_inliers_without_patching(campus_short):
    """A study-style observer through the constructor: per PnP the (N, 2) pixels and (N,) inlier mask; the
    inlier count is the frame's ``n_inliers``; a select hook that keeps every feature changes nothing, one that
    keeps the left half gives inliers only there."""
    from vo.dataset import open_dataset
    ds = open_dataset(campus_short)
    log, per_frame = [], {}

    def observe(px, inl):
        log.append((px, inl))

    def on_frame(frame, res, est):
        per_frame[frame.index] = (res, list(log))
        log.clear()

    plain = run_estimator("klt-pnp", ds, progress=False, max_frames=25)
    seen = run_estimator("klt-pnp", ds, {"pnp_observer": observe}, progress=False, max_frames=25, on_frame=on_frame)
    np.testing.assert_array_equal(seen.trajectory.T, plain.trajectory.T)
    pnp_frames = [k for k, (res, calls) in per_frame.items() if calls]
    assert len(pnp_frames) >= 20                       # every frame after the first keyframe solves a PnP
    for k in pnp_frames:
        res, calls = per_frame[k]
        assert len(calls) == 1
        px, inl = calls[0]
        assert px.ndim == 2 and px.shape[1] == 2 and inl.shape == (len(px),) and inl.dtype == bool
        assert int(inl.sum()) == res.n_inliers and len(px) == res.n_features
    everything = run_estimator("klt-pnp", ds, {"pnp_select": lambda px: np.ones(len(px), bool)}, progress=False,
                               max_frames=25)
    np.testing.assert_array_equal(everything.trajectory.T, plain.trajectory.T)
    half = ds.rig.cameras[0].width / 2
    log.clear()
    run_estimator("klt-pnp", ds, {"pnp_observer": observe, "pnp_select": lambda px: px[:, 0] < half},
                  progress=False, max_frames=25)
    assert log and all(not inl[px[:, 0] >= half].any() for px, inl in log)
    assert sum(inl.sum() for _, inl in log) > 0


@pytest.mark.slow
def test_rop_step_observer_inputs_resolve_the_step(campus_short):
    """rop's ``step_observer`` receives each step's pairs, R_1_3 and priors; ``solve_step`` from them gives the
    keyframe step the run took (same inputs, same solver: equal to rounding)."""
    from vo.dataset import open_dataset
    from vo.rop.estimator import RopEstimator
    ds = open_dataset(campus_short)
    seen, steps = {}, []

    def on_frame(frame, res, est):
        epoch = est.epochs[-1] if est.epochs else None
        if "in" in seen and epoch is not None and epoch.t_ns == frame.t_ns and epoch.kind == "rops":
            steps.append((seen["in"], epoch.T_kf_c_adjusted))
        seen.clear()

    run_estimator("rop", ds, {"step_observer": lambda *a: seen.update({"in": a})}, progress=False, max_frames=30,
                  on_frame=on_frame)
    assert len(steps) >= 5
    solver = RopEstimator(ds.rig)
    for (pairs, R_1_3, priors), T_run in steps:
        T = solver.solve_step(pairs, R_1_3, priors)
        assert T is not None
        np.testing.assert_allclose(T, T_run, atol=1e-9)


def test_rop_takes_its_tracker_through_the_constructor():
    """The injected tracker is the one the KLT front-end uses; with a descriptor front-end there is none to
    replace, which is an error rather than a silently unused collaborator."""
    from vo.errors import EstimatorError
    from vo.rop.estimator import RopEstimator
    from vo.rop.tracks import KltFourView
    rig = make_rig()
    tracker = KltFourView(rig)
    assert RopEstimator(rig, tracker=tracker).klt is tracker
    assert isinstance(RopEstimator(rig).klt, KltFourView) and RopEstimator(rig).klt is not tracker
    with pytest.raises(EstimatorError, match=r"rop: a tracker is the KLT front-end's; frontend is 'orb'"):
        RopEstimator(rig, tracker=tracker, frontend="orb")


def test_klt_pnp_takes_its_tracker_and_landmark_source_through_the_constructor(campus_short):
    """A study's landmark source and tracker, given to ``klt-pnp`` through its constructor: one that passes the
    product's own landmarks on (stereo KLT + triangulation) changes nothing; one that pushes every new landmark
    5 % farther makes the steps long (the source is what the map is built from); an injected tracker is the one
    used."""
    from vo.dataset import open_dataset
    from vo.estimators.pnp import KltPnpEstimator
    from vo.frontend.klt import KltConfig, KltTracker, stereo_klt
    from vo.frontend.stereo import triangulate
    ds = open_dataset(campus_short)
    cam = ds.rig.cameras[0]
    calls = []

    def source(scale):
        def landmarks(left, right, ids, p_l):
            cfg = est.pnp_config
            p_r, ok = stereo_klt(left, right, p_l, ds.rig, est.klt_config, est.tracker.pyramid)
            p_c0, ok_t = triangulate(ds.rig, p_l, p_r, cfg.max_depth, cfg.max_triangulation_px)
            calls.append(len(ids))
            return p_c0 * scale, ok & ok_t
        return landmarks

    plain = run_estimator("klt-pnp", ds, progress=False, max_frames=20)
    tracker = KltTracker(cam.width, cam.height, KltConfig())
    est = KltPnpEstimator(ds.rig, tracker=tracker, landmark_source=source(1.0))
    same = [est.process(f).T_o_c0 for f in ds.frames(stop=20)]
    assert est.tracker is tracker and calls and sum(calls) > 100
    np.testing.assert_allclose(np.array(same), plain.trajectory.T, atol=1e-9)
    est = KltPnpEstimator(ds.rig, landmark_source=source(1.05))
    far = [est.process(f).T_o_c0 for f in ds.frames(stop=20)]
    path = lambda T: np.sum(np.linalg.norm(np.diff(np.array(T)[:, :3, 3], axis=0), axis=1))  # noqa: E731
    assert path(far) / path(same) == pytest.approx(1.05, abs=0.02)


class RecordingAdjuster:
    """A keyframe adjuster that records its calls; ``shift`` (m, along x) moves each keyframe's pose and
    ``reject`` drops the landmarks with even ids."""

    def __init__(self, shift: float = 0.0, reject: bool = False):
        self.shift, self.reject = shift, reject
        self.resets, self.calls, self.returned = 0, [], []

    def reset(self):
        self.resets += 1

    def adjust(self, left, right, T_o_c0, ids, px, landmarks):
        self.calls.append((set(map(int, ids)), set(landmarks)))
        T = T_o_c0.copy()
        T[0, 3] += self.shift
        rejected = {i for i in landmarks if i % 2 == 0} if self.reject else set()
        self.returned.append(T)
        return T, landmarks, rejected


@pytest.mark.slow
def test_klt_pnp_takes_a_keyframe_adjuster_through_the_constructor(campus_short):
    """Seed 003's keyframe optimization slot: an adjuster that changes nothing leaves the trajectory as it is;
    it is reset on initialisation and called on every keyframe with the tracked ids and the current landmarks;
    the pose it returns is the keyframe's reported pose, and the landmarks it rejects leave the map."""
    from vo.dataset import open_dataset
    from vo.estimators.pnp import KltPnpEstimator
    ds = open_dataset(campus_short)
    plain = run_estimator("klt-pnp", ds, progress=False)
    same = RecordingAdjuster()
    res = run_estimator("klt-pnp", ds, {"keyframe_adjuster": same}, progress=False)
    np.testing.assert_allclose(res.trajectory.T, plain.trajectory.T, atol=1e-12)
    n_kf = sum(r.status == "keyframe" for r in plain.frames)
    assert same.resets == 1 and len(same.calls) == 1 + n_kf and n_kf >= 1
    assert all(lm <= ids for ids, lm in same.calls)            # landmarks are those of tracked ids
    moved = RecordingAdjuster(shift=0.1, reject=True)
    est = KltPnpEstimator(ds.rig, keyframe_adjuster=moved)
    out = [est.process(f) for f in ds.frames()]
    kf = [r for r in out if r.status == "keyframe"]
    assert kf and len(moved.returned) == 1 + len(kf)
    np.testing.assert_allclose(kf[0].T_o_c0, moved.returned[1], atol=1e-12)
    for ids, lm in moved.calls[2:]:                            # rejected (even) ids never come back
        assert not {i for i in lm if i % 2 == 0} & {i for _, l0 in moved.calls[1:2] for i in l0}
