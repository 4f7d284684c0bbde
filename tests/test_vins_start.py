"""VINS start-up and recovery: a start from rest initialises within the stated errors, a constant-speed start
stays in ``init`` and emits no pose, a divergence reinitialises with status ``reinit``."""
import os

os.environ.setdefault("MUJOCO_GL", "egl")

import numpy as np
import pytest

from vo.dataset.open import open_dataset
from vo.estimators.base import frame_class
from vo.vins.divergence import DivergenceCheck, Snapshot
from vo.vins.estimator import VinsEstimator
from studies import load_study

COVERED = ("ok", "keyframe")
InitRecorder = load_study("vins_start_table").InitRecorder
window_errors = load_study("vins_start_table").window_errors


def _urban(tmp_path_factory, name, duration_s, **motion):
    """The urban-static scenario's first ``duration_s`` (seed 0) as named: its own IMU, the paper's Xsens MTi 10
    from the datasheet (``xsens-mti10``). About 30 s to render 14 s."""
    from sim.generate import generate
    from sim.scenarios import SCENARIOS
    sets = [f"duration_s={duration_s}"] + [f"motion.{k}={v}" for k, v in motion.items()]
    cfg = SCENARIOS["urban-static"].with_overrides(sets)
    out = tmp_path_factory.mktemp(name)
    generate(cfg, out, progress=False)
    return out


@pytest.fixture(scope="module")
def urban_from_rest(tmp_path_factory):
    return _urban(tmp_path_factory, "vins_urban_rest", 14.0)


@pytest.fixture(scope="module")
def urban_cruise(tmp_path_factory):
    return _urban(tmp_path_factory, "vins_urban_cruise", 8.0, start_speed_mps=10.0)


def _run(path, **kw):
    """-> (estimator, recorder, results, window errors against the truth at the first pose or None)."""
    ds = open_dataset(path)
    rec = InitRecorder(ds.groundtruth_cam0())
    est = VinsEstimator(ds.rig, initializer=rec, **kw)
    est.set_imu(ds.imu)
    est.set_dataset(ds)
    res, at_pose = [], None
    for k in range(len(ds)):
        res.append(est.process(ds.frame(k)))
        if at_pose is None and res[-1].status in COVERED:
            at_pose = window_errors(est.window, ds.groundtruth_cam0())
    return est, rec, res, at_pose


class DivergeOnce:
    """A divergence test that declares the window diverged at its ``at``-th call (1-based), then defers to the
    default :class:`DivergenceCheck`."""

    def __init__(self, at: int = 1):
        self.at, self.calls, self.inner = at, 0, DivergenceCheck()

    def __call__(self, before, v_pred, after, newest_key):
        self.calls += 1
        return "diverged: forced by the test" if self.calls == self.at else self.inner(before, v_pred, after,
                                                                                        newest_key)


@pytest.mark.long
def test_start_from_rest_initialises_within_scale_and_gravity_errors(urban_from_rest):
    """From rest (the car accelerates from 0): `init` with the identity pose until the start succeeds, then a
    pose every frame; at the first pose the window's scale within 5 % and its tilt within 1 deg of the truth
    (the issue's targets: the start is the alignment refined and confirmed by the window's first
    optimisation, docs/vins.md), within 14 s; the alignment's gravity within 1 deg; no divergence afterwards
    (the default thresholds do not fire on a healthy run)."""
    est, rec, res, at_pose = _run(urban_from_rest)
    first = next(k for k, r in enumerate(res) if r.status != "init")
    assert res[first].message == "initialised" and res[first].status == "keyframe"
    assert all(np.array_equal(r.T_o_c0, np.eye(4)) for r in res[:first])
    assert all(r.status in COVERED for r in res[first:]), {r.status: r.message for r in res[first:]}
    assert abs(at_pose["window_scale_err_pct"]) <= 5.0 and at_pose["window_tilt_deg"] <= 1.0, at_pose
    assert rec.starts[-1]["gravity_err_deg"] <= 1.0, rec.starts


@pytest.mark.long
def test_constant_speed_start_stays_in_init_and_emits_no_pose(urban_cruise):
    """At a constant 10 m/s the scale is unobservable: every frame is `init` with the identity pose, and the
    attempts are refused for observability (IMU excitation or the scale's standard deviation), not accepted."""
    est, rec, res, _ = _run(urban_cruise)
    assert all(r.status == "init" and frame_class(r) == "init" for r in res)
    assert all(np.array_equal(r.T_o_c0, np.eye(4)) for r in res)
    assert not rec.starts
    msgs = {r.message for r in res}
    assert any("not observable" in m or "excitation" in m for m in msgs), msgs


@pytest.mark.long
def test_forced_divergence_reinitialises(urban_from_rest):
    """A divergence injected at the first window optimisation after the start: the window is dropped and the
    start begins again from fresh keyframes (the initializer is called again on them); that frame and every
    frame until a new start succeeds are `reinit` (not `init`: a pose was produced before) with the last pose
    held and the frame class `lost` (not covered by the evaluation). On this route the divergence comes at
    about 7 s, when the car is at speed: the windows after it span about 2 s of nearly constant acceleration
    and are refused for observability within the 14 s (docs/vins.md), so a second start is checked only if it
    happens: then it is announced as `initialised` and covers every frame after it. The attempts after the
    divergence are at least ``reinit_attempt_interval_s`` (0.5 s) apart."""
    ds = open_dataset(urban_from_rest)
    rec = CountingRecorder(ds.groundtruth_cam0())
    est = VinsEstimator(ds.rig, initializer=rec, divergence=DivergeOnce(1))
    est.set_imu(ds.imu)
    est.set_dataset(ds)
    res = []
    for k in range(len(ds)):
        res.append(est.process(ds.frame(k)))
        if len(res) >= 2 and res[-2].status != "init" and res[-1].status == "reinit" and rec.calls_at_reinit is None:
            rec.calls_at_reinit = rec.calls
    first = next(k for k, r in enumerate(res) if r.status != "init")
    assert res[first + 1].status == "reinit" and res[first + 1].message == "diverged: forced by the test"
    again = next((k for k in range(first + 2, len(res)) if res[k].message == "initialised"), len(res))
    assert again > first + 2
    assert all(r.status == "reinit" for r in res[first + 1:again])
    assert all(frame_class(r) == "lost" for r in res[first + 1:again])         # not covered by the evaluation
    assert all(np.array_equal(r.T_o_c0, res[first].T_o_c0) for r in res[first + 1:again])
    msgs = [r.message for r in res[first + 2:again]]
    assert "collecting keyframes 1/11" in msgs, msgs[:5]                       # fresh keyframes
    assert rec.calls > rec.calls_at_reinit                                     # the start is tried again
    t_reinit = np.array(rec.t_ns[rec.calls_at_reinit:])                        # reinit_attempt_interval_s
    assert np.all(np.diff(t_reinit) >= 0.5e9), np.diff(t_reinit)
    assert any("not observable" in m or "SfM failed" in m for m in msgs), set(msgs)
    if again < len(res):
        assert all(r.status in COVERED for r in res[again:]) and len(rec.starts) == 2


class CountingRecorder(InitRecorder):
    """:class:`InitRecorder` that also counts the start attempts (``calls``)."""

    def __init__(self, gt):
        super().__init__(gt)
        self.calls, self.calls_at_reinit, self.t_ns = 0, None, []

    def __call__(self, *args):
        self.calls += 1
        self.t_ns.append(args[2][-1].t_ns)          # the newest keyframe of the attempt
        return super().__call__(*args)


def _snap(p, v=(10.0, 0, 0), ba=(0, 0, 0), bg=(0, 0, 0)):
    return Snapshot({k: np.asarray(x, float) for k, x in p.items()}, np.asarray(v, float), np.asarray(ba, float),
                    np.asarray(bg, float))


def test_divergence_check_fires_on_each_failure_and_not_on_a_healthy_step():
    """A window of states 1 m apart moving at 10 m/s: the next frame 1 m on passes; each of VINS-Mono's
    failures (biases, a 5 m step, a 1 m vertical step) and the added velocity and scale jumps is named."""
    chk = DivergenceCheck()
    before = _snap({0: (0, 0, 0), 1: (1, 0, 0), 2: (2, 0, 0)})
    ok = _snap({0: (0, 0, 0), 1: (1, 0, 0), 2: (2, 0, 0), 3: (3, 0, 0)})
    assert chk(before, np.array([10.0, 0, 0]), ok, 3) is None
    cases = {
        "accelerometer bias": _snap(ok.positions, ba=(3.0, 0, 0)),
        "gyro bias": _snap(ok.positions, bg=(0, 1.5, 0)),
        "step": _snap({**ok.positions, 3: (8.0, 0, 0)}),
        "vertical step": _snap({**ok.positions, 3: (3.0, 0, 1.5)}),
        "velocity jump": _snap(ok.positions, v=(13.0, 0, 0)),
        "window scale": _snap({0: (0, 0, 0), 1: (1.5, 0, 0), 2: (3.0, 0, 0), 3: (4.0, 0, 0)}),
    }
    for name, after in cases.items():
        why = chk(before, np.array([10.0, 0, 0]), after, 3)
        assert why is not None and why.startswith("diverged: " + name.split()[0]), (name, why)


def test_imu_excitation_is_zero_at_constant_velocity_and_sees_a_speed_change():
    """Noise-free IMU: constant velocity gives 0; a 1 m/s^2 acceleration in half of the intervals gives the
    sample standard deviation of the interval means (0 and 1 m/s^2 alternating over 10 intervals: 0.527)."""
    import gtsam
    from rigs.records import ImuSamples
    from vo.vins.vins_config import VinsConfig
    from vo.vins.feature_tracker import FeatureFrame
    from vo.vins.imu import ImuStream, imu_params
    from vo.vins.vi_init import imu_excitation
    t = np.arange(0, 2001) * 5_000_000                          # 10 s at 200 Hz
    seg = (t // 1_000_000_000) % 2 == 1                         # accelerate in odd seconds
    acc = np.zeros((len(t), 3))
    acc[:, 2] = 9.81
    frames = [FeatureFrame(int(k * 1e9), np.zeros(0, np.int64), np.zeros((0, 2)), np.zeros((0, 2)),
                           np.zeros(0, np.int64)) for k in range(11)]
    params = imu_params(VinsConfig(), None)
    params.setAccelerometerCovariance(np.zeros((3, 3)))
    still = ImuStream(ImuSamples(t, np.zeros((len(t), 3)), acc.copy()))
    assert imu_excitation(still, params, frames) == pytest.approx(0.0, abs=1e-9)
    acc[seg, 0] = 1.0
    moving = ImuStream(ImuSamples(t, np.zeros((len(t), 3)), acc))
    expect = np.std(np.arange(10) % 2, ddof=1)
    assert imu_excitation(moving, params, frames) == pytest.approx(expect, rel=0.02)
    assert isinstance(params, gtsam.PreintegrationCombinedParams)


class ScaledStart:
    """The default start with its scale multiplied by ``factor`` (a wrongly scaled alignment, as an SfM that
    misplaces a keyframe gives in traffic), recorded by :class:`InitRecorder`."""

    def __init__(self, gt, factor: float):
        from vo.vins.vi_init import initialize
        self.factor, self.rec = factor, InitRecorder(gt, inner=self._scaled)
        self._inner = initialize

    def _scaled(self, *args):
        r, msg = self._inner(*args)
        if r is not None:
            r.scale *= self.factor
            r.v_v = r.v_v * self.factor
        return r, msg

    def __call__(self, *args):
        return self.rec(*args)


@pytest.mark.long
def test_a_start_the_window_does_not_confirm_is_refused(urban_from_rest):
    """Every accepted alignment scaled by 1.15: the window's first optimisation moves the scale back by more
    than ``init_window_check`` (5 %), so the start is refused with "scale not confirmed", no pose is emitted
    (identity, status `init`) and the start is tried again on later windows."""
    ds = open_dataset(urban_from_rest)
    start = ScaledStart(ds.groundtruth_cam0(), 1.15)
    est = VinsEstimator(ds.rig, initializer=start)
    est.set_imu(ds.imu)
    est.set_dataset(ds)
    res = [est.process(ds.frame(k)) for k in range(len(ds))]
    refused = [k for k, r in enumerate(res) if r.message.startswith("scale not confirmed")]
    assert refused, {r.message for r in res}
    k0 = refused[0]
    assert all(r.status == "init" and np.array_equal(r.T_o_c0, np.eye(4)) for r in res[:k0 + 1])
    assert any("collecting" not in r.message for r in res[k0 + 1:])              # the start goes on
    for k in range(k0 + 1, len(res)):
        if res[k].status in COVERED:                                           # a later start: confirmed
            assert res[k].message == "initialised"
            break
