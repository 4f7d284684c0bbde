"""Look-alike places: does a scene contain two distinct places that a SLAM loop closure would take for one?

Places are sampled every ``spacing_m`` along the scenario's route (the vehicle on the route, looking along it);
at each a *revisit* is rendered as well: the vehicle 1 m further on, 0.8 m to the side, turned by 10 deg (a
second pass through the same place, within the width of a lane or path and an ordinary heading difference). Each image is compared with every other by what a loop closure verifies:
ORB features (OpenCV, 1000 per image), nearest-neighbour matches that pass Lowe's ratio test (0.8), then the
geometric check a loop closure makes: image A's matched features, back-projected with A's rendered depth, must
project onto their matches in B under one rigid motion (PnP RANSAC, 2 px), in front of B. The RANSAC draws 300
minimal samples (AP3P: 3 points and one to choose among its solutions), as ORB-SLAM2's ``Sim3Solver`` draws 3
points for each of at most 300 hypotheses; EPnP's 5-point samples found the motion of a revisit whose matches
were 26 % right (65 of 254: a view filled by the calibration board's corners) in 30 % of runs (1 - (1 - 0.26^5)^300),
AP3P's in 75 %. Each feature of B takes
one match (its closest), as a loop closure's matcher does. The *similarity* of two images is the number of
inliers at distinct image places (:func:`distinct_places`: inliers closer to each other than the RANSAC tolerance
in A or in B are one place, ``min`` over A and B), so the check is well conditioned: ORB detects one corner at
several pyramid levels, up to a few pixels apart, and a degenerate fit that projects many points of A onto one
point of B (a far-away pose that PnP RANSAC accepts, found on the lunar traverse: 49 inliers on 3 pixels of B)
counts for what it is, one or a few places. A consensus of at most :data:`MINIMAL_SAMPLE` places (the matches each
RANSAC hypothesis is fitted to: AP3P's 3 and the 1 that chooses among its solutions, 4) is what any set of matches
yields and no evidence of a common place: such a pair's similarity is *unverified* (measured on the indoor
scene, seeds 0-9: 1202 of 1210 distinct pairs, all of their matches wrong by construction, score at most 4, the
others 5-6).
(A fundamental-matrix check is too weak here: driving along a straight street the epipolar
lines are the street's own lines, so matches anywhere along a lane marking pass it.)

Which pairs are distinct places is decided from the exact geometry, not from the route: a pixel grid of image A
(every 8 px, rendered depth < 80 m) is back-projected and projected into image B; a point is *co-visible* when it
lands inside B in front of the camera and B's depth there agrees (within 5 % + 0.1 m). Two images are distinct
places when fewer than ``overlap_max`` (1 %) of either one's points are co-visible in the other. Genuinely
revisited places: each place with its revisit.

The check passes when no distinct pair is as similar as the least similar revisit, ``max(distinct) <
min(revisits)``, and none reaches :data:`LOOP_ACCEPT_INLIERS`, the 40 matches with which ORB-SLAM2's loop closing
accepts a loop candidate (``LoopClosing::ComputeSim3``: ``nTotalMatches >= 40``): a distinct pair above it is a
false loop closure waiting to happen. Unverified similarities (at most the minimal sample) count as none: the
check passes when no distinct pair is verified at all, or when every verified one is less similar than every
revisit (an unverified revisit, a view with too few matches to verify such as a plain wall at a grazing angle,
counting 0: then no verified distinct pair is allowed). Unverified revisits are reported.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from rigs.geometry import make_T, rot_z
from sim.errors import SimError
from sim.generate import resolve
from sim.sensors.camera import StereoCamera

LOOP_ACCEPT_INLIERS = 40
MINIMAL_SAMPLE = {"pnp": 4, "fundamental": 7}   # a RANSAC hypothesis's sample: AP3P 3 + 1 to choose; 7-point F


@dataclass(frozen=True)
class PlaceConfig:
    spacing_m: float = 2.0
    revisit_forward_m: float = 1.0
    revisit_side_m: float = 0.8
    revisit_yaw_deg: float = 10.0
    n_features: int = 1000
    ratio: float = 0.8
    ransac_px: float = 2.0
    overlap_max: float = 0.01
    grid_px: int = 8
    max_depth_m: float = 80.0
    verify: str = "pnp"          # geometric check: "pnp" (3-D, a rigid motion) or "fundamental" (2-D, epipolar)
    actor_clear_m: float = 9.0   # actors this close to a view's vehicle are left out of it (a bus: 5.5 m half)

    def __post_init__(self):
        if self.verify not in ("pnp", "fundamental"):
            raise SimError(f"places verify: 'pnp' or 'fundamental', got {self.verify!r}")

    @property
    def minimal_sample(self) -> int:
        """Matches a RANSAC hypothesis of the geometric check is fitted to: a consensus this small is no evidence."""
        return MINIMAL_SAMPLE[self.verify]


@dataclass
class View:
    """One rendered view: grey left image, depth (m, inf = nothing), T_w_c (4,4), intrinsics K (3,3)."""

    image: np.ndarray
    depth: np.ndarray
    T_w_c: np.ndarray
    K: np.ndarray
    arc_m: float


def route_place_poses(scene, spacing_m: float) -> tuple:
    """``(T_w_b (N,4,4), arc (N,))``: body poses every ``spacing_m`` along the route polyline (the scene's
    ``path_xy``, or its route's waypoints where it has none: the lunar traverse's legs), yaw along it."""
    xy = np.asarray(scene.path_xy if hasattr(scene, "path_xy") else scene.route.waypoints_xy, float)
    if scene.route.closed:
        xy = np.vstack([xy, xy[:1]])
    seg = np.diff(xy, axis=0)
    s_cum = np.concatenate([[0.0], np.cumsum(np.linalg.norm(seg, axis=1))])
    s = np.arange(0.5 * spacing_m, s_cum[-1] - 1.0, spacing_m)
    if len(s) < 2:
        raise SimError(f"places: the route ({s_cum[-1]:.1f} m) is too short for spacing {spacing_m} m")
    k = np.clip(np.searchsorted(s_cum, s, side="right") - 1, 0, len(seg) - 1)
    p = xy[k] + seg[k] * ((s - s_cum[k]) / np.linalg.norm(seg[k], axis=1))[:, None]
    yaw = np.arctan2(seg[k, 1], seg[k, 0])
    z = np.asarray(scene.ground_height(p[:, 0], p[:, 1]), float)
    return np.array([make_T(rot_z(a), [x, y, zz]) for a, (x, y), zz in zip(yaw, p, z)]), s


def revisit_pose(T_w_b: np.ndarray, config: PlaceConfig) -> np.ndarray:
    """The second pass through a place: forward, sideways and turned (body frame x forward, y left)."""
    d = make_T(rot_z(np.radians(config.revisit_yaw_deg)), [config.revisit_forward_m, config.revisit_side_m, 0.0])
    return T_w_b @ d


def render_views(config, place: PlaceConfig = PlaceConfig(), progress: bool = True) -> tuple:
    """``(places, revisits)``: lists of :class:`View` of the scenario ``config`` (a GenerateConfig); actors at
    the scenario's start time."""
    from tqdm import tqdm

    setup = resolve(config.with_value("duration_s", 1.0) if config.duration_s is None else config)
    scene, rig = setup.scene, setup.rig
    T_places, arcs = route_place_poses(scene, place.spacing_m)
    cam = rig.cameras[0]
    K = np.array([[cam.fx, 0, cam.cx], [0, cam.fy, cam.cy], [0, 0, 1.0]])
    actors = scene.actor_states(int(setup.frame_t_ns[0]))
    places, revisits = [], []
    with StereoCamera(scene, rig, vehicle=config.vehicle, depth=True) as camera:
        T_b_c = cam.T_b_c_array
        for T, s in tqdm(list(zip(T_places, arcs)), desc="render places", unit="place", disable=not progress):
            for T_b, out in ((T, places), (revisit_pose(T, place), revisits)):
                imgs, depth, _ = camera.measure(T_b, clear_of_actors(actors, T_b, place.actor_clear_m))
                out.append(View(imgs[0], np.asarray(depth[0], float), T_b @ T_b_c, K, float(s)))
    return places, revisits


def clear_of_actors(actors: dict, T_w_b: np.ndarray, clear_m: float) -> dict:
    """``actors`` ({body: T_w_actor (4,4)}) with those whose origin is within ``clear_m`` (horizontally) of the
    vehicle at ``T_w_b`` moved 1 km below the ground: the places are sampled along the route with the actors at
    the start time, so a place can fall on a vehicle standing in the route's lane (``urban-dynamic``'s own-lane
    platoon), which would put the camera inside it."""
    out = {}
    for name, T in actors.items():
        T = np.array(T, float)
        if np.hypot(*(T[:2, 3] - T_w_b[:2, 3])) < clear_m:
            T[2, 3] -= 1000.0
        out[name] = T
    return out


def covisible_fraction(a: View, b: View, place: PlaceConfig = PlaceConfig()) -> float:
    """Fraction of ``a``'s grid points (finite depth < max) that ``b`` sees (in front, inside, depth agrees)."""
    g = place.grid_px
    v, u = np.mgrid[g // 2:a.depth.shape[0]:g, g // 2:a.depth.shape[1]:g]
    z = a.depth[v, u]
    ok = np.isfinite(z) & (z > 0) & (z < place.max_depth_m)
    if not ok.any():
        return 0.0
    u, v, z = u[ok].astype(float), v[ok].astype(float), z[ok]
    p_c = np.linalg.solve(a.K, np.vstack([u, v, np.ones_like(u)])) * z
    p_w = a.T_w_c[:3, :3] @ p_c + a.T_w_c[:3, 3:4]
    T_c_w = np.linalg.inv(b.T_w_c)
    q = T_c_w[:3, :3] @ p_w + T_c_w[:3, 3:4]
    front = q[2] > 0.05
    uv = (b.K @ q[:, front])
    ub, vb = uv[0] / uv[2], uv[1] / uv[2]
    H, W = b.depth.shape
    inside = (ub >= 0) & (vb >= 0) & (ub <= W - 1) & (vb <= H - 1)
    zb = b.depth[np.rint(vb[inside]).astype(int), np.rint(ub[inside]).astype(int)]
    agree = np.abs(zb - q[2, front][inside]) < 0.05 * q[2, front][inside] + 0.1
    return float(agree.sum()) / float(ok.sum())


def distinct_places(x: np.ndarray, radius_px: float) -> int:
    """Number of distinct image places among points ``x`` (N, 2): kept greedily in order of ``x``, a point
    within ``radius_px`` of one kept is the same place (ORB finds one corner at several pyramid levels, a few
    pixels apart; the geometric check cannot tell points within its tolerance apart)."""
    x = np.asarray(x, float).reshape(-1, 2)
    kept = np.empty((0, 2))
    for p in x:
        if not len(kept) or np.min(np.hypot(*(kept - p).T)) >= radius_px:
            kept = np.vstack([kept, p])
    return len(kept)


class OrbMatcher:
    """ORB features once per image; :meth:`inliers`: the matches a loop closure would verify, in distinct places."""

    def __init__(self, place: PlaceConfig = PlaceConfig()):
        import cv2
        self.cv2, self.place = cv2, place
        self.orb = cv2.ORB_create(nfeatures=place.n_features)
        self.bf = cv2.BFMatcher(cv2.NORM_HAMMING)
        self._cache = {}

    def features(self, key, image):
        if key not in self._cache:
            kp, des = self.orb.detectAndCompute(image, None)
            self._cache[key] = (np.array([k.pt for k in kp], np.float32).reshape(-1, 2), des)
        return self._cache[key]

    def inliers(self, fa, fb, return_matches: bool = False, view_a: "View | None" = None):
        """Similarity of features ``fa`` -> ``fb``: ratio-test matches, one per feature of B (the closest; as a
        loop closure's matcher, ORB-SLAM's ``SearchByBoW``, takes each feature of the candidate once), that
        survive a well-conditioned geometric check: with ``view_a`` (its depth and intrinsics) a PnP RANSAC of A's
        back-projected points in B whose inliers lie in front of B (a rigid motion explains them, as a loop
        closure's Sim3 / projection check demands, ``SearchBySim3`` drops points behind the camera), else a
        fundamental-matrix RANSAC. The similarity counts distinct image places (:func:`distinct_places`, within
        the RANSAC tolerance: ORB's pyramid levels detect one corner several times), ``min`` over A and B, so
        a degenerate fit that sends many points of A onto one point of B scores 1, not its number of inliers."""
        cv2 = self.cv2
        (pa, da), (pb, db) = fa, fb
        none = (0, np.empty((0, 2)), np.empty((0, 2))) if return_matches else 0
        if da is None or db is None or len(da) < 8 or len(db) < 8:
            return none
        good = {}
        for m in self.bf.knnMatch(da, db, k=2):
            if len(m) == 2 and m[0].distance < self.place.ratio * m[1].distance:
                if m[0].trainIdx not in good or m[0].distance < good[m[0].trainIdx].distance:
                    good[m[0].trainIdx] = m[0]
        good = sorted(good.values(), key=lambda m: m.queryIdx)
        if len(good) < 8:
            return none
        xa = pa[[m.queryIdx for m in good]]
        xb = pb[[m.trainIdx for m in good]]
        if view_a is not None:
            ui = np.clip(np.rint(xa[:, 0]).astype(int), 0, view_a.depth.shape[1] - 1)
            vi = np.clip(np.rint(xa[:, 1]).astype(int), 0, view_a.depth.shape[0] - 1)
            z = view_a.depth[vi, ui]
            ok = np.isfinite(z) & (z > 0) & (z < self.place.max_depth_m)
            if ok.sum() < 6:
                return none
            xa, xb, z = xa[ok], xb[ok], z[ok]
            P = (np.linalg.solve(view_a.K, np.vstack([xa.T, np.ones(len(xa))])) * z).T
            # minimal samples (AP3P: 3 points + 1 to choose), as ORB-SLAM2's 3-point Sim3 RANSAC (300 iterations)
            found, rvec, tvec, idx = cv2.solvePnPRansac(P.astype(np.float64), xb.astype(np.float64), view_a.K, None,
                                                        iterationsCount=300, reprojectionError=self.place.ransac_px,
                                                        confidence=0.999, flags=cv2.SOLVEPNP_AP3P)
            keep = np.zeros(len(xa), bool)
            if found and idx is not None:
                keep[idx.ravel()] = True
                R = cv2.Rodrigues(rvec)[0]
                keep &= (P @ R[2] + float(tvec.ravel()[2])) > 0                  # in front of B
        else:
            _, mask = cv2.findFundamentalMat(xa, xb, cv2.FM_RANSAC, self.place.ransac_px, 0.999)
            if mask is None:
                return none
            keep = mask.ravel() == 1
        xa, xb = xa[keep], xb[keep]
        r = self.place.ransac_px
        n = min(distinct_places(xa, r), distinct_places(xb, r))
        return (n, xa, xb) if return_matches else n


@dataclass(frozen=True)
class PlaceCheck:
    """Similarities (distinct inlier places) of the revisits and of the distinct-place pairs; a similarity of at
    most ``minimal_sample`` is unverified and counts as none (module docstring)."""

    source: str
    n_places: int
    revisit: np.ndarray               # (N,) place i with its revisit
    distinct: np.ndarray              # (M,) distinct pairs
    distinct_pairs: np.ndarray        # (M, 2) image indices (0..2N-1: places then revisits)
    arcs: np.ndarray                  # (N,) arc length of each place (m)
    n_covisible_pairs: int
    minimal_sample: int = MINIMAL_SAMPLE["pnp"]

    def verified(self, s) -> np.ndarray:
        """``s`` with the unverified similarities (at most the minimal sample) set to 0."""
        s = np.asarray(s, int)
        return np.where(s > self.minimal_sample, s, 0)

    @property
    def passed(self) -> bool:
        if not len(self.revisit):
            return False
        top = int(self.verified(self.distinct).max()) if len(self.distinct) else 0
        return bool(top < LOOP_ACCEPT_INLIERS and (top == 0 or top < self.verified(self.revisit).min()))

    def worst(self) -> tuple:
        """(i, j, inliers) of the most similar distinct pair (image indices)."""
        k = int(np.argmax(self.distinct))
        return int(self.distinct_pairs[k, 0]), int(self.distinct_pairs[k, 1]), int(self.distinct[k])

    def _where(self, i) -> str:
        n = self.n_places
        return f"{'revisit' if i >= n else 'place'} {i % n} ({self.arcs[i % n]:.0f} m)"

    def to_dict(self) -> dict:
        ok = self.revisit > self.minimal_sample
        d = {"source": self.source, "places": self.n_places, "revisit_min": int(self.revisit.min()),
             "revisit_median": float(np.median(self.revisit)), "distinct_pairs": int(len(self.distinct)),
             "covisible_pairs_skipped": self.n_covisible_pairs, "minimal_sample": self.minimal_sample,
             "revisits_unverified": [self._where(i) for i in np.flatnonzero(~ok)],
             "revisit_verified_min": int(self.revisit[ok].min()) if ok.any() else None, "passed": self.passed}
        if len(self.distinct):
            i, j, n = self.worst()
            d.update({"distinct_max": n, "distinct_p99": float(np.percentile(self.distinct, 99)),
                      "distinct_median": float(np.median(self.distinct)),
                      "distinct_verified": int((self.distinct > self.minimal_sample).sum()),
                      "distinct_over_revisit_min": int((self.verified(self.distinct) >= max(
                          1, int(self.verified(self.revisit).min()))).sum()),
                      "distinct_over_loop_accept": int((self.distinct >= LOOP_ACCEPT_INLIERS).sum()),
                      "worst_pair": [self._where(i), self._where(j)]})
        if d["revisit_verified_min"] is not None:
            d["margin"] = d["revisit_verified_min"] - d.get("distinct_max", 0)
        return d

    def table(self) -> str:
        d = self.to_dict()
        ms = self.minimal_sample
        unver = d["revisits_unverified"]
        lines = [f"place recognition: {self.source}, {self.n_places} places + revisits, "
                 f"{d['distinct_pairs']} distinct pairs ({d['covisible_pairs_skipped']} co-visible pairs left out)",
                 f"  ORB + ratio test + RANSAC inliers in distinct places: revisits min {d['revisit_min']}, median "
                 f"{d['revisit_median']:.0f}; weakest verified {d['revisit_verified_min']}, {len(unver)} unverified "
                 f"(at most the {ms}-match minimal sample){': ' + ', '.join(unver) if unver else ''}"]
        if len(self.distinct):
            lines.append(f"  distinct places: max {d['distinct_max']} ({d['worst_pair'][0]} vs {d['worst_pair'][1]}), "
                         f"99th percentile {d['distinct_p99']:.0f}, median {d['distinct_median']:.0f}; "
                         f"{d['distinct_verified']} verified (above {ms}), "
                         f"{d['distinct_over_revisit_min']} pair(s) verified at or above the weakest revisit, "
                         f"{d['distinct_over_loop_accept']} at or above a loop closure's {LOOP_ACCEPT_INLIERS}")
        margin = f", margin {d['margin']}" if "margin" in d else ""
        lines.append(f"  {'PASS' if self.passed else 'FAIL'}{margin} (no verified distinct pair as similar as the "
                     f"weakest revisit or reaching {LOOP_ACCEPT_INLIERS}; margin: weakest verified revisit - most "
                     f"similar distinct pair)")
        return "\n".join(lines)


def check_places(places, revisits, source: str, place: PlaceConfig = PlaceConfig(), progress: bool = True) -> tuple:
    """``(PlaceCheck, matcher)`` over every pair of the 2N views (places then revisits)."""
    from tqdm import tqdm
    views = list(places) + list(revisits)
    n = len(places)
    m = OrbMatcher(place)
    feats = [m.features(k, v.image) for k, v in enumerate(views)]
    pnp = place.verify == "pnp"
    revisit = np.array([m.inliers(feats[i], feats[n + i], view_a=views[i] if pnp else None) for i in range(n)])
    dist, pairs, n_cov = [], [], 0
    todo = [(i, j) for i in range(2 * n) for j in range(i + 1, 2 * n) if j != i + n]
    for i, j in tqdm(todo, desc="compare", unit="pair", disable=not progress, mininterval=2.0):
        if max(covisible_fraction(views[i], views[j], place), covisible_fraction(views[j], views[i], place)) \
                >= place.overlap_max:
            n_cov += 1
            continue
        dist.append(m.inliers(feats[i], feats[j], view_a=views[i] if pnp else None))
        pairs.append((i, j))
    res = PlaceCheck(source, n, revisit, np.array(dist, int), np.array(pairs, int).reshape(-1, 2),
                     np.array([v.arc_m for v in places]), n_cov, place.minimal_sample)
    return res, m


def plot_places(res: PlaceCheck, places, revisits, matcher, path) -> None:
    """Histogram of the similarities (distinct pairs against revisits) and the most similar distinct pair with
    its inlier matches."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    views = list(places) + list(revisits)
    fig = plt.figure(figsize=(11, 7.5))
    ax = fig.add_subplot(2, 1, 1)
    top = max(int(res.revisit.max()), int(res.distinct.max()) if len(res.distinct) else 1)
    bins = np.concatenate([[0.0], np.unique(np.round(np.logspace(0, np.log10(top + 2), 40)))])
    if len(res.distinct):
        ax.hist(res.distinct, bins=bins, color="tab:red", alpha=0.6, label=f"distinct places ({len(res.distinct)} pairs)")
    ax.hist(res.revisit, bins=bins, color="tab:green", alpha=0.6, label=f"revisits ({len(res.revisit)})")
    ax.axvline(res.revisit.min(), color="tab:green", ls="--", lw=1)
    ax.axvline(LOOP_ACCEPT_INLIERS, color="k", ls=":", lw=1, label=f"loop accepted ({LOOP_ACCEPT_INLIERS})")
    ax.axvspan(0, res.minimal_sample + 0.5, color="0.85", zorder=0, label=f"unverified (<= {res.minimal_sample})")
    ax.set_xscale("symlog", linthresh=1.0)
    ax.set_xlim(left=0)
    ax.set_yscale("log")
    ax.set_xlabel(f"ORB matches surviving ratio test + {'PnP' if matcher.place.verify == 'pnp' else 'F'} RANSAC, "
                  f"in places {matcher.place.ransac_px:g} px apart")
    ax.set_ylabel("pairs")
    ax.set_title(f"{res.source}: {'PASS' if res.passed else 'FAIL'}", fontsize=10)
    ax.legend(fontsize=8)
    if len(res.distinct):
        i, j, n = res.worst()
        _, xa, xb = matcher.inliers(matcher.features(i, views[i].image), matcher.features(j, views[j].image), True,
                                    view_a=views[i] if matcher.place.verify == "pnp" else None)
        a, b = views[i].image, views[j].image
        both = np.hstack([a, b])
        ax2 = fig.add_subplot(2, 1, 2)
        ax2.imshow(both, cmap="gray", vmin=0, vmax=255)
        for p, q in zip(xa, xb):
            ax2.plot([p[0], q[0] + a.shape[1]], [p[1], q[1]], "-", color="yellow", lw=0.5)
        ax2.set_axis_off()
        ax2.set_title(f"most similar distinct places: {res._where(i)} vs {res._where(j)}, {n} places", fontsize=9)
    fig.tight_layout()
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=100)
    plt.close(fig)
