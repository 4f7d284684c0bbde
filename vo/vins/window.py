"""Sliding-window visual-inertial factor graph (seed 002 §3.4-3.5, eq. 20/31) on gtsam.

States per frame (eq. 2): ``X(k)`` Pose3 ``T_w_i`` (IMU = body), ``V(k)`` velocity in w, ``B(k)`` the
accelerometer and gyro biases. Camera-IMU extrinsics (eq. 3) are fixed from the calibration.

Features (option ``landmark``):
* ``"inverse-depth"`` (eq. 3, 14-19): ``L(j)`` is a 1-vector, the inverse depth of the feature in its anchor,
  the first window state that observes it; each later observation is a unit-sphere residual
  (:mod:`vo.vins.inverse_depth`; one Python ``CustomFactor`` per (anchor, observer) pair of states, each
  observation with its own sigma and robust loss). When the anchor is marginalized the feature's depth moves
  to the next observing state (VINS-Mono's ``shift_depth``).
* ``"point3"`` (the default, for speed): ``L(j)`` is a gtsam ``Point3`` in w and the residual gtsam's built-in
  image-plane reprojection (``GenericProjectionFactorCal3_S2`` on undistorted pixels, the extrinsics as its
  ``body_P_sensor``), about 10x cheaper than the custom factor. For the same noise the image-plane and
  tangent-plane residuals agree to first order near the image centre (the cameras here are < 100 deg);
  every observation, the first included, is a residual. A track whose landmark was marginalized continues
  as a new landmark once it is re-triangulated (at once, at its estimate, with ``shift_depth``).
The adaptive weights and the Huber loss are carried per factor in both.

Window (n = ``window_size`` states, the two strategies of §3.4): when a frame arrives and the previous
newest frame is not a keyframe, that frame is dropped with its visual measurements and the IMU is
pre-integrated from the keyframe before it (the IMU information is kept); when it is a keyframe and the
window is full, the oldest state is marginalized with the landmarks it observes by the Schur complement
(``eliminatePartialSequential``) into a ``LinearContainerFactor`` prior. With ``hold_gauge`` the window is
moved back after each optimization so that its oldest state keeps its position and yaw (VINS-Mono).
"""
from __future__ import annotations

from dataclasses import dataclass

import gtsam
import numpy as np
from gtsam.symbol_shorthand import B, L, V, X

from vo.vins.adaptive import geometry_factor, noise_model, residual_sigma, robust_kernel
from vo.vins.covariance import pose_block_marginal
from vo.vins.imu import preintegrate
from vo.vins.inverse_depth import inverse_depth_group, inverse_depth_of, point_of

LANDMARK_PRIOR_M = 1e3      # std of the regularising landmark prior of pose_covariance
MARG_PRIOR_RELATIVE = 3e-8     # landmark prior of marginalization, relative to its bearing information
INIT_DEPTH_M = 5.0             # inverse-depth landmarks: depth where two-view triangulation fails (VINS-Mono)


@dataclass
class State:
    k: int                     # key index
    t_ns: int
    feats: object              # FeatureFrame
    is_kf: bool
    g_f: float = float("nan")      # eq. 25 of this image, fixed when the state is added


class Window:
    def __init__(self, config, camera, T_i_c: np.ndarray, imu_stream, imu_params):
        self.cfg, self.stream, self.params = config, imu_stream, imu_params
        self.K = gtsam.Cal3_S2(camera.fx, camera.fy, 0.0, camera.cx, camera.cy)
        self.fx = camera.fx
        self.T_i_c = np.asarray(T_i_c, float)
        self.P_i_c = gtsam.Pose3(self.T_i_c)
        self.inv_depth = config.landmark == "inverse-depth"
        self.anchor: dict = {}          # inverse depth: track id -> (anchor state k, its normalized xy)
        self.noise_depends_on_n = config.use_track_count or config.robust == "adaptive-huber"
        self.states: list[State] = []
        self.values = gtsam.Values()
        self.priors: list = []
        self.lm: dict = {}              # track id -> landmark key index
        self.next_lm = 0
        self.next_k = 0
        self.cache: dict = {}           # state k -> {landmark key: (N, factor)}
        self.noise_cache: dict = {}     # (state k, N) -> noise model
        self.pims: dict = {}            # (state k, state k') -> pre-integration, bias-corrected to first order
        self.counts: dict = {}          # track id -> N, times tracked up to the newest frame (eq. 26, 30)

    # ------------------------------------------------------------------ state management
    def add_state(self, t_ns: int, feats, is_kf: bool, T_w_i=None, v_w=None, bias=None) -> State:
        """Append a state; without a given pose it is predicted from the newest state by the IMU."""
        st = State(self.next_k, int(t_ns), feats, is_kf)
        self.next_k += 1
        if T_w_i is None:
            prev = self.states[-1]
            b = self.values.atConstantBias(B(prev.k))
            pim = preintegrate(self.stream, self.params, prev.t_ns, st.t_ns, b)
            nav = pim.predict(gtsam.NavState(self.values.atPose3(X(prev.k)), self.values.atVector(V(prev.k))), b)
            pose, vel, bias = nav.pose(), nav.velocity(), b
        else:
            pose, vel = gtsam.Pose3(np.asarray(T_w_i, float)), np.asarray(v_w, float)
        self.values.insert(X(st.k), pose)
        self.values.insert(V(st.k), vel)
        self.values.insert(B(st.k), bias)
        self.states.append(st)
        self.counts.update(zip(feats.ids.tolist(), feats.count.tolist()))
        self.set_geometry(st)
        return st

    def drop_second_newest(self) -> None:
        """§3.4 strategy 2: remove the second-newest (non-keyframe) state and its visual measurements."""
        st = self.states.pop(-2)
        for i in [i for i, (k, _) in self.anchor.items() if k == st.k]:
            self.remove_landmark(i)
        for key in (X(st.k), V(st.k), B(st.k)):
            self.values.erase(key)
        self._forget(st.k)

    def _forget(self, k: int) -> None:
        self.cache.pop(k, None)
        self.noise_cache = {nk: m for nk, m in self.noise_cache.items() if nk[0] != k}
        self.pims = {pk: p for pk, p in self.pims.items() if k not in pk}

    def set_geometry(self, st: State) -> None:
        """g_f of the image (eq. 22-25) from the landmarks it sees and its (predicted) camera position."""
        p_w = [self.landmark_w(i) for i in st.feats.ids.tolist() if i in self.lm]
        st.g_f = geometry_factor(np.array(p_w).reshape(-1, 3), self.T_w_c(st)[:3, 3])

    # ------------------------------------------------------------------ landmarks
    def add_landmark(self, track: int, p_w: np.ndarray) -> None:
        """A landmark at the world point ``p_w`` (as the inverse depth in its anchor: INIT_DEPTH_M if behind)."""
        key = self.next_lm
        self.next_lm += 1
        self.lm[int(track)] = key
        if not self.inv_depth:
            self.values.insert(L(key), gtsam.Point3(*np.asarray(p_w, float)))
            return
        st, xy = self.first_observation(int(track))
        rho = inverse_depth_of(p_w, self.T_w_c(st)) if p_w is not None else float("nan")
        self.anchor[int(track)] = (st.k, xy)
        self.values.insert(L(key), np.array([rho if np.isfinite(rho) else 1.0 / INIT_DEPTH_M]))

    def first_observation(self, track: int):
        """(state, normalized xy) of the oldest window state observing ``track``."""
        for st in self.states:
            if track in st.feats.id_set:
                return st, st.feats.xy[int(np.flatnonzero(st.feats.ids == track)[0])].copy()
        raise KeyError(track)

    def landmark_w(self, track: int) -> np.ndarray:
        """World position (3,) of the landmark of ``track``."""
        key = L(self.lm[track])
        if not self.inv_depth:
            return self.values.atPoint3(key)
        k, xy = self.anchor[track]
        return point_of(self.values.atVector(key)[0], xy, self._T_w_c_of(k))

    def remove_landmark(self, track: int) -> None:
        key = self.lm.pop(int(track))
        self.anchor.pop(int(track), None)
        self.values.erase(L(key))
        for per_state in self.cache.values():
            per_state.pop(key, None)

    def _window_counts(self) -> dict:
        """track id -> number of window states observing it (VINS-Mono's ``used_num``; ``n_count=window``)."""
        out: dict = {}
        for st in self.states:
            for i in st.feats.ids.tolist():
                out[i] = out.get(i, 0) + 1
        return out

    def _factor(self, st: State, track: int, xy: np.ndarray, n: int | None = None):
        """Point3 reprojection factor of ``track`` in ``st``; its noise uses the image's g_f and the feature's
        current N (eq. 26: N_{f,t,l} at the optimisation epoch t; ``n``, else counted here), so it is rebuilt
        when N changes."""
        if n is None:
            n = (self._window_counts() if self.cfg.n_count == "window" else self.counts).get(track, 1)
        if not self.noise_depends_on_n:
            n = 0                         # the same noise for every N: keep the factor across frames
        key = self.lm[track]
        per_state = self.cache.setdefault(st.k, {})
        hit = per_state.get(key)
        if hit is None or hit[0] != n:
            noise = self.noise_cache.get((st.k, n))
            if noise is None:
                noise = self.noise_cache[(st.k, n)] = noise_model(self.cfg, st.g_f, n, self.fx)
            uv = np.array([self.K.fx() * xy[0] + self.K.px(), self.K.fy() * xy[1] + self.K.py()])
            f = gtsam.GenericProjectionFactorCal3_S2(uv, noise, X(st.k), L(key), self.K, False, False, self.P_i_c)
            hit = per_state[key] = (n, f)
        return hit[1]

    # ------------------------------------------------------------------ graph
    def imu_factor(self, a: State, b: State):
        """CombinedImuFactor a -> b; the pre-integration is computed once per pair at the bias estimate of that
        time and corrected to first order for later bias estimates (gtsam, as VINS-Mono's Jacobians)."""
        pim = self.pims.get((a.k, b.k))
        if pim is None:
            pim = self.pims[(a.k, b.k)] = preintegrate(self.stream, self.params, a.t_ns, b.t_ns,
                                                       self.values.atConstantBias(B(a.k)))
        return gtsam.CombinedImuFactor(X(a.k), V(a.k), X(b.k), V(b.k), B(a.k), B(b.k), pim)

    def observations(self, states=None, tracks=None):
        """(state, track id, normalized xy, N) of every reprojection residual of ``states`` (all by default)
        on landmarks (of ``tracks`` if given); N is the front-end count (``n_count=track``) or the number of
        observing window states (``n_count=window``), both as of the newest frame. An inverse-depth anchor
        observation is no residual."""
        counts = self._window_counts() if self.cfg.n_count == "window" else self.counts
        for st in (self.states if states is None else states):
            for i, xy in zip(st.feats.ids.tolist(), st.feats.xy):
                if i in self.lm and (tracks is None or i in tracks) and \
                        not (self.inv_depth and self.anchor[i][0] == st.k):
                    yield st, i, xy, counts.get(i, 1)

    def visual_factors(self, states=None, tracks=None) -> list:
        """Reprojection factors of :meth:`observations`: one per observation (point3), or one per (anchor,
        observer) pair of states (inverse depth, :func:`vo.vins.inverse_depth.inverse_depth_group`)."""
        if not self.inv_depth:
            return [self._factor(st, i, xy, n) for st, i, xy, n in self.observations(states, tracks)]
        groups: dict = {}
        for st, i, xy, n in self.observations(states, tracks):
            k_a, xy_a = self.anchor[i]
            kind, c = robust_kernel(self.cfg, n)
            groups.setdefault((k_a, st.k, kind), []).append(
                (L(self.lm[i]), xy_a, xy, residual_sigma(self.cfg, st.g_f, n, 1.0), c))
        return [inverse_depth_group(X(k_a), X(k_j), [o[0] for o in obs], np.array([o[1] for o in obs]),
                                    np.array([o[2] for o in obs]), self.T_i_c, np.array([o[3] for o in obs]),
                                    kind, np.array([o[4] for o in obs]))
                for (k_a, k_j, kind), obs in groups.items()]

    def graph(self) -> gtsam.NonlinearFactorGraph:
        g = gtsam.NonlinearFactorGraph()
        for p in self.priors:
            g.add(p)
        for a, b in zip(self.states[:-1], self.states[1:]):
            g.add(self.imu_factor(a, b))
        for f in self.visual_factors():
            g.add(f)
        return g

    def optimize(self) -> None:
        self._drop_single_observations()
        g = self.graph()
        params = gtsam.LevenbergMarquardtParams()
        params.setMaxIterations(self.cfg.lm_iterations)
        before = self.values.atPose3(X(self.states[0].k))
        self.values = gtsam.LevenbergMarquardtOptimizer(g, self.values, params).optimize()
        if self.cfg.hold_gauge:
            self._hold_gauge(before)
        self._reject_bad_landmarks()

    def _hold_gauge(self, T_before: gtsam.Pose3) -> None:
        """VINS-Mono's ``double2vector``: position and yaw are unobservable, so after the optimization the whole
        window (poses, velocities, world landmarks) is moved by the rotation about the vertical and the shift
        that put the oldest state back at its position and yaw from before it (roll and pitch are observable
        through gravity and keep their optimized values)."""
        T_after = self.values.atPose3(X(self.states[0].k))
        yaw = lambda R: np.arctan2(R[1, 0], R[0, 0])                      # noqa: E731
        dyaw = yaw(T_before.rotation().matrix()) - yaw(T_after.rotation().matrix())
        R_d = gtsam.Rot3.Rz(dyaw)
        p0_before, p0_after = T_before.translation(), T_after.translation()
        move = lambda p: R_d.matrix() @ (np.asarray(p) - p0_after) + p0_before     # noqa: E731
        for st in self.states:
            T = self.values.atPose3(X(st.k))
            self.values.update(X(st.k), gtsam.Pose3(R_d.compose(T.rotation()), move(T.translation())))
            self.values.update(V(st.k), R_d.matrix() @ self.values.atVector(V(st.k)))
        if not self.inv_depth:
            for key in self.lm.values():
                self.values.update(L(key), gtsam.Point3(*move(self.values.atPoint3(L(key)))))

    def _drop_single_observations(self) -> None:
        """Remove landmarks seen by fewer than two window states (VINS-Mono optimises features with
        ``used_num >= 2``): dropping a non-keyframe can leave a landmark with one observation, which does not
        constrain its depth and makes the linear system indeterminate."""
        n_obs = self._window_counts()
        for i in [i for i in self.lm if n_obs.get(i, 0) < 2]:
            self.remove_landmark(i)

    def _reject_bad_landmarks(self) -> None:
        """Drop landmarks behind, closer than 0.1 m to or farther than 10 km from any observing camera
        (VINS-Mono's failed-depth removal); an inverse depth at or below 1e-4 m^-1 is the same 10 km."""
        bad = {i for i, key in self.lm.items() if self.inv_depth and not self.values.atVector(L(key))[0] > 1e-4}
        p_w = {i: self.landmark_w(i) for i in self.lm if i not in bad}
        for st in self.states:
            T_c_w = self.values.atPose3(X(st.k)).compose(self.P_i_c).inverse()
            for i in st.feats.ids:
                i = int(i)
                if i in self.lm and i not in bad:
                    z = T_c_w.transformFrom(p_w[i])[2]
                    if not 0.1 < z < 1e4:
                        bad.add(i)
        for i in bad:
            self.remove_landmark(i)

    # ------------------------------------------------------------------ marginalization
    def marginalize_oldest(self) -> None:
        """§3.4 strategy 1: Schur complement of the oldest state and the landmarks it observes.

        A landmark seen with little parallax has a near-singular 3x3 information block, and gtsam's
        elimination refuses it (indeterminate system); :meth:`_landmark_regularisers` keeps it defined.
        Landmarks are eliminated first, each 3x3 block on its own, then the oldest state."""
        old = self.states[0]
        keep_states = self.states if self.states[-1].is_kf else self.states[:-1]
        seen = {int(i) for i in old.feats.ids if int(i) in self.lm}
        n_obs = {i: sum(i in st.feats.id_set for st in keep_states) for i in seen}
        tracks = {i for i in seen if n_obs[i] >= 2}
        for i in seen - tracks:                 # a single observation carries no information on a point
            self.remove_landmark(i)
        lm_keys = [L(self.lm[i]) for i in tracks]
        marg = lm_keys + [X(old.k), V(old.k), B(old.k)]    # landmarks first: each 3x3 block on its own
        mset = set(marg)
        g = gtsam.NonlinearFactorGraph()
        rest = []
        for p in self.priors:
            (g.add(p) if mset.intersection(p.keys()) else rest.append(p))
        g.add(self.imu_factor(self.states[0], self.states[1]))
        for f in self.visual_factors(keep_states, tracks) + \
                self._landmark_regularisers(keep_states, tracks, self.T_w_c(old)[:3, 3]):
            g.add(f)
        lin = g.linearize(self.values)
        _, remaining = lin.eliminatePartialSequential(gtsam.Ordering(marg))
        factors = [f for f in (remaining.at(j) for j in range(remaining.size())) if f is not None]
        sub = gtsam.Values()
        for key in {k for f in factors for k in f.keys()}:
            c = gtsam.Symbol(key).chr()
            sub.insert(key, self.values.atPose3(key) if c == ord("x") else
                       self.values.atVector(key) if c == ord("v") else self.values.atConstantBias(key))
        self.priors = rest + [gtsam.LinearContainerFactor(f, sub) for f in factors]
        moved = {i: self.landmark_w(i) for i in tracks} if self.inv_depth or self.cfg.shift_depth else {}
        for i in tracks:
            self.remove_landmark(i)
        self.states.pop(0)
        for key in (X(old.k), V(old.k), B(old.k)):
            self.values.erase(key)
        self._forget(old.k)
        n_obs = self._window_counts()
        for i, p_w in moved.items():         # shift_depth: the track continues, anchored at its next observer
            if n_obs.get(i, 0) >= 2:
                self.add_landmark(i, p_w)

    def _landmark_regularisers(self, states, tracks, c_w: np.ndarray) -> list:
        """A prior at the estimate of each landmark of ``tracks`` observed in ``states``, whose information
        is ``MARG_PRIOR_RELATIVE`` times the bearing information of its observations (sum of (f/sigma_px)^2
        over them, divided by the squared range from ``c_w``). VINS-Mono inverts the landmark block by a
        pseudo-inverse (eigenvalues below a threshold dropped); a relative Tikhonov term does the same job
        in gtsam: it bounds the block's condition at any range and weight (adaptive weights included), and
        along a ray it adds 3e-8 of a bearing's information. gtsam refuses a landmark seen from 11 identical
        poses below about 2e-9 (``tests/test_vins_window.py``)."""
        info: dict = {}
        for st, i, _, n in self.observations(states, tracks):
            key = L(self.lm[i])
            info[key] = info.get(key, 0.0) + (1.0 / residual_sigma(self.cfg, st.g_f, n, 1.0)) ** 2
        out = []
        for key, bearing in info.items():
            if self.inv_depth:          # the same information along the ray: sigma_rho = rho / sqrt(c bearing)
                rho = self.values.atVector(key)
                noise = gtsam.noiseModel.Isotropic.Sigma(1, abs(rho[0]) / np.sqrt(MARG_PRIOR_RELATIVE * bearing))
                out.append(gtsam.PriorFactorVector(key, rho, noise))
                continue
            p_w = self.values.atPoint3(key)
            r = max(float(np.linalg.norm(p_w - c_w)), 0.1)
            sigma_m = r / np.sqrt(MARG_PRIOR_RELATIVE * bearing)
            out.append(gtsam.PriorFactorPoint3(key, p_w, gtsam.noiseModel.Isotropic.Sigma(3, sigma_m)))
        return out

    # ------------------------------------------------------------------ outputs
    def T_w_c(self, st: State) -> np.ndarray:
        return self._T_w_c_of(st.k)

    def _T_w_c_of(self, k: int) -> np.ndarray:
        return self.values.atPose3(X(k)).compose(self.P_i_c).matrix()

    def pose_covariance(self, st: State):
        """6x6 marginal covariance of X(k) (gtsam's tangent [rotation, translation], body frame).

        The window's Gauss-Newton information ``H`` (gtsam's linearization at the estimate, robust weights
        included) is inverted for the X(k) block by a dense solve (numpy). gtsam's ``Marginals`` refuses
        the window: landmarks seen with little parallax make the system nearly singular along their depth,
        where LM's damping does not mind. Each landmark gets a weak prior (``LANDMARK_PRIOR_M`` std at its
        estimate; 1e-6 m^-2 of information) so that ``H`` is invertible; it changes the pose marginal by far
        less than its own size."""
        return self._leading_marginal([X(st.k)])

    def velocity_covariance(self, st: State) -> np.ndarray:
        """3x3 marginal covariance of V(k) in w, computed as :meth:`pose_covariance` (the same weak landmark
        priors and Schur complements). At speed, the relative standard deviation of the speed is that of the
        window's scale: the camera sees the motion only up to scale, the IMU fixes it."""
        return self._leading_marginal([V(st.k), X(st.k)])[:3, :3]

    def _leading_marginal(self, first_keys: list) -> np.ndarray:
        """6x6 marginal covariance of the leading block of ``first_keys`` (ordered first), landmarks and the
        other states Schur-complemented out of the window's information with weak landmark priors."""
        g = self.graph()
        for i in self.lm:
            g.add(self._weak_landmark_prior(i))
        lm_keys = [L(key) for key in self.lm.values()]
        lm_set = set(lm_keys)
        keys = list(dict.fromkeys(first_keys + [k for k in g.keyVector() if k not in lm_set])) + lm_keys
        H, _ = g.linearize(self.values).hessian(gtsam.Ordering(keys))
        d = 1 if self.inv_depth else 3
        return pose_block_marginal(H, H.shape[0] - d * len(lm_keys), d)

    def _weak_landmark_prior(self, track: int):
        """``LANDMARK_PRIOR_M`` std at the estimate; for an inverse depth the same std along the ray
        (d p / d rho = |m_a| / rho^2)."""
        key = L(self.lm[track])
        if not self.inv_depth:
            return gtsam.PriorFactorPoint3(key, self.values.atPoint3(key),
                                           gtsam.noiseModel.Isotropic.Sigma(3, LANDMARK_PRIOR_M))
        rho = self.values.atVector(key)
        m_a = np.append(self.anchor[track][1], 1.0)
        sigma = LANDMARK_PRIOR_M * rho[0] ** 2 / np.linalg.norm(m_a)
        return gtsam.PriorFactorVector(key, rho, gtsam.noiseModel.Isotropic.Sigma(1, max(sigma, 1e-12)))

