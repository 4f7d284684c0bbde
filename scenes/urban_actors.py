"""Moving actors of the urban scene: cars in the traffic lanes and pedestrians on sidewalks and crossings.

Each actor is a mocap body ``urban/actor_<k>`` (k = 1, 2, ...) whose geoms are named
``dyn/urban/actor_<k>/<part>`` (the renderer flags every ``dyn/`` geom as dynamic in segmentation). Its
pose is an exact, smooth function of time drawn once from the simulator's ``dynamic`` random stream:

* ``line`` actors (cars, buses, sidewalk pedestrians) move along a straight lane through ``origin_xy`` in the
  direction ``heading``: ``s(t) = v t + sum_k a_k sin(w_k t + phi_k)``, with ``sum_k a_k w_k < v`` so they never
  stop or reverse; speed ``s'`` and acceleration ``s''`` are continuous, ``|s''| <= sum_k a_k w_k^2``. All
  actors of a lane share ``v`` and start in slots of ``span / count`` (jittered by ``Lane.jitter``, 15 %), and the swing
  ``sum_k a_k`` is at most :data:`MAX_SWING_M`, so actors of one lane keep their order and spacing;
  With ``Lane.start_tau_s = tau > 0`` the steady part is ``v (t - tau (1 - exp(-t / tau)))`` for ``t >= 0``
  (at rest before): the actor starts from rest with the vehicle (acceleration at most ``v / tau``);
* ``shuttle`` actors (pedestrians on a zebra crossing) walk back and forth across the road,
  ``s(t) = (W / 2) sin(w t + phi)``, facing along the crossing.

``t`` is seconds since :data:`T_REF_NS` (the simulator's default start time), so ``origin_xy`` is where
the actor is when a default run starts. An actor that does not move (``moving`` false: all of them at
``scene.dynamic_density = 0``) stands at ``origin_xy`` for the whole run. Yaw is constant per actor.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from scenes.actor_sheets import add_sheets, sheet_uv
from scenes.actor_textures import cell_uv
from scenes.bus_shapes import draw_bus_body
from scenes.car_shapes import draw_body
from scenes.urban_actor_poses import ActorPoser

ACTOR_SCOPE = "urban/actor_"
GEOM_PREFIX = "dyn/"
T_REF_NS = 1_000_000_000
MAX_SWING_M = 1.0            # bound on an actor's position swing about its lane's steady motion (m)
# parts: (name, half size, centre in the actor frame, atlas cell per face +x, -x, +y, -y, +z, -z); the first is the
# body whose footprint the contact check uses. Wheels: (radius, half width, centres).
CAR_PARTS = (("body", (2.2, 0.9, 0.35), (0.0, 0.0, 0.65),
              ("front", "rear", "body_side", "body_side", "paint", "under")),
             ("cabin", (1.2, 0.8, 0.3), (-0.2, 0.0, 1.3),
              ("windscreen", "windscreen", "cabin_side", "cabin_side", "paint", "under")))
BUS_PARTS = (("body", (5.5, 1.25, 2.1), (0.0, 0.0, 2.3), ("front", "rear", "side", "side", "roof", "under")),)
PED_PARTS = (("legs", (0.14, 0.2, 0.42), (0.0, 0.0, 0.42),
              ("legs_front", "legs_front", "legs_side", "legs_side", "legs_side", "legs_side")),
             ("torso", (0.16, 0.25, 0.3), (0.0, 0.0, 1.14),
              ("torso_front", "torso_front", "torso_side", "torso_side", "shoulders", "shoulders")),
             ("head", (0.11, 0.1, 0.13), (0.0, 0.0, 1.57), ("face", "hair", "head_side", "head_side", "hair", "head_side")))
WHEELS = {"car": (0.32, 0.12, tuple((x, y, 0.32) for x in (-1.36, 1.36) for y in (-0.8, 0.8))),
          "bus": (0.5, 0.15, tuple((x, y, 0.5) for x in (-3.3, 3.3) for y in (-1.15, 1.15))),
          "pedestrian": (0.0, 0.0, ())}
SHAPES = {"car": (CAR_PARTS, 1.0), "bus": (BUS_PARTS, 2.0), "pedestrian": (PED_PARTS, 0.5)}   # parts, (unused) tile
SPECULAR = {"car": 0.35, "bus": 0.25, "pedestrian": 0.05}           # painted bodies and glass shine, clothes do not


@dataclass(frozen=True)
class Lane:
    """A straight line actors of ``kind`` move along: through ``point_xy`` with direction ``heading``
    (rad from world x); origins are drawn with along-lane offsets in ``span`` (m); speeds in ``speed``."""

    kind: str
    point_xy: tuple
    heading: float
    span: tuple
    speed: tuple
    count: int
    mode: str = "line"
    width_m: float = 0.0        # shuttle: crossing length
    bus_share: float = 0.0      # car lanes: probability that an actor is a double-decker bus
    route_lane: bool = False    # the vehicle's own lane: actors that do not move are left out
    jitter: float = 0.15        # slot jitter (fraction of the slot length)
    start_tau_s: float = 0.0    # > 0: actors start at rest at T_REF and approach ``v`` with this time constant


@dataclass(frozen=True)
class Actor:
    """One actor; ``amp``/``omega``/``phase`` (K,) are its speed modulation (line) or crossing (shuttle)."""

    actor_id: int
    kind: str
    mode: str
    origin_xy: tuple
    heading: float
    speed: float
    amp: tuple
    omega: tuple
    phase: tuple
    variant: int                # drawn with the actor (keeps the stream's draws); the atlas is by actor id
    moving: bool
    start_tau: float = 0.0

    @property
    def body_name(self) -> str:
        return f"{ACTOR_SCOPE}{self.actor_id}"

    def arc(self, t: np.ndarray) -> tuple:
        """(s, s', s'') (each (N,)) along the heading at seconds ``t``."""
        t = np.asarray(t, float)
        if not self.moving:
            z = np.zeros_like(t)
            return z, z, z
        a, w, p = (np.asarray(x, float)[:, None] for x in (self.amp, self.omega, self.phase))
        arg = w * t[None] + p
        s = (a * np.sin(arg)).sum(0)
        sd = (a * w * np.cos(arg)).sum(0)
        sdd = -(a * w * w * np.sin(arg)).sum(0)
        if self.mode == "line" and self.start_tau > 0:                    # from rest: v (t - tau (1 - e^(-t/tau)))
            tau, tp = self.start_tau, np.maximum(t, 0.0)
            e = np.exp(-tp / tau)
            s = s + self.speed * (tp - tau * (1 - e))
            sd, sdd = sd + self.speed * (1 - e), sdd + np.where(t >= 0, self.speed / tau * e, 0.0)
        elif self.mode == "line":
            s, sd = s + self.speed * t, sd + self.speed
        return s, sd, sdd

    def max_accel(self) -> float:
        """Bound on ``|s''|`` (m/s^2)."""
        if not self.moving:
            return 0.0
        start = self.speed / self.start_tau if self.start_tau > 0 else 0.0
        return float(np.sum(np.abs(self.amp) * np.square(self.omega))) + start

    def poses(self, t_ns) -> np.ndarray:
        """(N, 4, 4) ``T_w_actor`` at int64 ``t_ns``: actor frame x forward, z up, origin on the ground."""
        t = (np.asarray(t_ns, np.int64).reshape(-1) - np.int64(T_REF_NS)).astype(float) * 1e-9
        s = self.arc(t)[0]
        d = np.array([np.cos(self.heading), np.sin(self.heading)])
        T = np.tile(np.eye(4), (t.size, 1, 1))
        T[:, :2, 3] = np.asarray(self.origin_xy) + s[:, None] * d
        c, sn = np.cos(self.heading), np.sin(self.heading)
        T[:, :2, :2] = [[c, -sn], [sn, c]]
        return T


def draw_actors(lanes, density: float, rng: np.random.Generator) -> tuple:
    """Actors of every lane from ``rng`` (the ``dynamic`` stream): origins, speeds, modulation, textures.
    A seeded permutation picks ``round(density * n)`` of the ``n`` actors to move; the draws do not depend
    on ``density``, so changing it only switches actors between moving and standing (standing actors of a
    ``route_lane`` are left out: the vehicle would drive through them)."""
    actors, in_route_lane, k = [], [], 1
    for lane in lanes:
        v_lane = rng.uniform(*lane.speed)                                     # one speed per lane: no overtaking
        gap = (lane.span[1] - lane.span[0]) / lane.count                        # within a lane, slots of ``gap``
        for i in range(lane.count):
            off = lane.span[0] + (i + 0.5 + lane.jitter * rng.uniform(-1.0, 1.0)) * gap
            d = np.array([np.cos(lane.heading), np.sin(lane.heading)])
            origin = np.asarray(lane.point_xy, float) + off * d
            v = rng.uniform(*lane.speed) if lane.mode == "shuttle" else v_lane
            kind = "bus" if lane.kind == "car" and rng.random() < lane.bus_share else lane.kind
            if lane.mode == "shuttle":
                amp, om = (lane.width_m / 2,), (v / (lane.width_m / 2),)        # peak speed v
                ph = (rng.uniform(0, 2 * np.pi),)
            else:
                om = rng.uniform(0.3, 0.9, 2) * (2.0 if lane.kind == "pedestrian" else 1.0)
                dv = np.minimum(rng.uniform(0.03, 0.06, 2) * v, om * MAX_SWING_M / 2)   # speed swing < 0.12 v
                if lane.start_tau_s > 0:
                    dv = 0.0 * dv                                                # starts from rest: no swing
                om, amp, ph = tuple(om), tuple(dv / om), tuple(rng.uniform(0, 2 * np.pi, 2))
            actors.append(Actor(k, kind, lane.mode, tuple(origin.round(4)), float(lane.heading), float(v),
                                amp, om, ph, int(rng.integers(0, 8)), False, float(lane.start_tau_s)))
            in_route_lane.append(lane.route_lane)
            k += 1
    n_move = int(round(float(density) * len(actors)))
    movers = set(rng.permutation(len(actors))[:n_move].tolist())
    return tuple(_with_moving(a, i in movers) for i, a in enumerate(actors) if i in movers or not in_route_lane[i])


def _with_moving(a: Actor, moving: bool) -> Actor:
    from dataclasses import replace
    return replace(a, moving=bool(moving))


def actor_poses(actors, t_ns: int) -> dict:
    """``{body name: (4,4) T_w_actor}`` of every actor at one time (the renderer's dynamic state): as
    ``{a.body_name: a.poses([t_ns])[0]}``, all actors in one pass (:class:`scenes.urban_actor_poses.ActorPoser`,
    kept for the last ``actors`` tuple seen)."""
    poser = _POSER.get("last")
    if poser is None or poser.actors is not actors:
        poser = _POSER["last"] = ActorPoser(actors, T_REF_NS)
    return poser.at(t_ns)


_POSER: dict = {}


def footprint_overlap(T_a, half_a, T_b, half_b) -> np.ndarray:
    """(N,) True where the rectangle of half sizes ``half_a`` (2,) (length, width) at the planar poses ``T_a``
    (N,4,4; x forward, yaw from the first column) meets the rectangle ``half_b`` at ``T_b`` (separating-axis test)."""
    def axes(T):                                           # (N,2,2) columns: unit forward, unit left
        f = T[:, :2, 0] / np.linalg.norm(T[:, :2, 0], axis=1, keepdims=True)
        return np.stack([f, np.stack([-f[:, 1], f[:, 0]], 1)], 2)
    Ra, Rb = axes(np.asarray(T_a, float)), axes(np.asarray(T_b, float))
    d = np.asarray(T_b, float)[:, :2, 3] - np.asarray(T_a, float)[:, :2, 3]
    apart = np.zeros(len(d), bool)
    for R in (Ra, Rb):
        for k in range(2):
            ax = R[:, :, k]
            ra = np.abs(np.einsum("ni,nij->nj", ax, Ra)) @ np.asarray(half_a, float)
            rb = np.abs(np.einsum("ni,nij->nj", ax, Rb)) @ np.asarray(half_b, float)
            apart |= np.abs(np.einsum("ni,ni->n", d, ax)) > ra + rb
    return ~apart


def first_contact(actors, t_ns, T_w_b, footprint, near_m: float = 15.0):
    """``(t_ns, actor_id, kind)`` of the earliest time in ``t_ns`` (N,) at which a car or bus footprint (its
    body box) meets the vehicle's at ``T_w_b`` (N,4,4), ``footprint`` = ``(x_centre_b, half_length, half_width)``
    (m); None when none does. Pedestrians are not checked (they keep to sidewalks and crossings)."""
    t_ns = np.asarray(t_ns, np.int64).reshape(-1)
    T = np.array(T_w_b, float)
    x_c, half_ego = float(footprint[0]), np.asarray(footprint[1:3], float)
    T[:, :3, 3] += T[:, :3, 0] * x_c                          # footprint centre in w
    best = None
    for a in actors:
        if a.kind == "pedestrian":
            continue
        Ta = a.poses(t_ns)
        near = np.flatnonzero(np.linalg.norm(Ta[:, :2, 3] - T[:, :2, 3], axis=1) < near_m)
        if near.size == 0:
            continue
        hit = near[footprint_overlap(T[near], half_ego, Ta[near], SHAPES[a.kind][0][0][1][:2])]
        if hit.size and (best is None or t_ns[hit[0]] < best[0]):
            best = (int(t_ns[hit[0]]), a.actor_id, a.kind)
    return best


# ---------------------------------------------------------------------------- MJCF
def parts_mesh(kind: str, parts=None, wheels=None) -> tuple:
    """(vertices, texcoords, faces) of a ``kind`` actor: the union of its boxes (each face onto its atlas cell,
    :mod:`scenes.actor_textures`) and its wheels (octagonal prisms along y, caps onto the ``tyre`` cell).
    ``parts`` / ``wheels``: as :data:`CAR_PARTS` / :data:`WHEELS` (None: the kind's own; a parked car passes
    its body's, :mod:`scenes.car_shapes`)."""
    v, uv, f = [], [], []

    def face(pts, cells_uv, n):
        k = len(v)
        v.extend(pts)
        uv.extend(cells_uv)
        tris = [[k, k + j, k + j + 1] for j in range(1, len(pts) - 1)]            # a fan (convex faces)
        if np.dot(np.cross(pts[1] - pts[0], pts[2] - pts[0]), n) < 0:
            tris = [[a, c, b] for a, b, c in tris]
        f.extend(tris)

    for _, half, centre, cells in (SHAPES[kind][0] if parts is None else parts):
        half, centre = np.asarray(half, float), np.asarray(centre, float)
        for ax in range(3):
            ua, va = [a for a in range(3) if a != ax]
            for j, sgn in enumerate((1.0, -1.0)):
                pts, tex = [], []
                for cu, cv in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
                    p = np.zeros(3)
                    p[ax], p[ua], p[va] = sgn * half[ax], cu * half[ua], cv * half[va]
                    pts.append(p + centre)
                    tex.append(cell_uv(kind, cells[2 * ax + j], (cu + 1) / 2, (1 - cv) / 2))
                n = np.zeros(3)
                n[ax] = sgn
                face(pts, [tuple(map(float, t)) for t in tex], n)
    radius, hw, centres = WHEELS[kind] if wheels is None else wheels
    ang = np.linspace(0.0, 2 * np.pi, 9)[:-1]
    for c in centres:
        c = np.asarray(c, float)
        ring = [np.array([radius * np.cos(a), 0.0, radius * np.sin(a)]) for a in ang]
        for sgn in (1.0, -1.0):                                           # caps: the tyre and its hub
            pts = [c + r + np.array([0.0, sgn * hw, 0.0]) for r in ring]
            tex = [tuple(map(float, cell_uv(kind, "tyre", 0.5 + 0.5 * np.cos(a), 0.5 - 0.5 * np.sin(a)))) for a in ang]
            face(pts, tex, np.array([0.0, sgn, 0.0]))
        for i in range(8):                                                # tread
            r0, r1 = ring[i], ring[(i + 1) % 8]
            pts = [c + r0 + [0, -hw, 0], c + r1 + [0, -hw, 0], c + r1 + [0, hw, 0], c + r0 + [0, hw, 0]]
            tex = [tuple(map(float, cell_uv(kind, "tyre", fu, fv))) for fu, fv in ((0, 0), (0.05, 0), (0.05, 0.05), (0, 0.05))]
            face(pts, tex, 0.5 * (r0 + r1))
    return np.ravel(v).tolist(), np.ravel(uv).tolist(), np.ravel(f).tolist()


def add_actors(spec, builder, actors) -> None:
    """Add one mocap body per actor, posed at its start, carrying one textured mesh geom
    ``dyn/urban/actor_<k>/body``, mesh ``mesh/urban/actor_<k>``. Every actor is one of its own: a car or bus has a
    body of its own (:func:`actor_shape`, stream ``urban/actor-shape/<k>``): a car :func:`scenes.car_shapes.draw_body`,
    fitted into the footprint of :data:`CAR_PARTS`; a bus :func:`scenes.bus_shapes.draw_bus_body`, inside the
    footprint of :data:`BUS_PARTS`; every actor an atlas of its own (stream ``texture/urban-actor/<kind>/<k>``, laid
    out for its body: :func:`scenes.actor_sheets.actor_look`), tiled with others into sheets, one material each
    (:func:`scenes.actor_sheets.add_sheets`). Standing vehicles (``urban-static``) are places a loop closure could
    confuse."""
    import mujoco
    footprint = CAR_PARTS[0][1][:2]
    shapes = {a.actor_id: actor_shape(builder, a, footprint) for a in actors}
    looks = add_sheets(builder, actors, shapes, SPECULAR)
    for a in actors:
        h = a.heading
        body = spec.worldbody.add_body(name=a.body_name, mocap=True, pos=[*map(float, a.origin_xy), 0.0],
                                       quat=[float(np.cos(h / 2)), 0.0, 0.0, float(np.sin(h / 2))])
        shape, (mat, tile) = shapes[a.actor_id], looks[a.actor_id]
        meshname = f"mesh/{a.body_name}"                                  # a mesh of its own, into its tile
        v, uv, f = parts_mesh(a.kind, *((shape.parts(), shape.wheels()) if shape is not None else ()))
        m = spec.add_mesh(name=meshname)
        m.uservert, m.usertexcoord, m.userface = v, sheet_uv(a.kind, uv, tile), f
        body.add_geom(name=f"{GEOM_PREFIX}{a.body_name}/body", type=mujoco.mjtGeom.mjGEOM_MESH,
                      meshname=meshname, material=mat, contype=0, conaffinity=0, group=1)


def actor_shape(builder, a: Actor, footprint):
    """Actor ``a``'s own body (stream ``urban/actor-shape/<k>``): a :class:`scenes.car_shapes.CarBody` fitted into
    ``footprint``, a :class:`scenes.bus_shapes.BusBody`; None for a pedestrian."""
    rng = builder.streams(f"urban/actor-shape/{a.actor_id}")
    return draw_bus_body(rng) if a.kind == "bus" else draw_body(rng).fitted(footprint) if a.kind == "car" else None


def actor_of_geom(geom_name: str) -> int:
    """Actor id of a geom ``dyn/urban/actor_<k>/<part>``; -1 for anything else."""
    prefix = GEOM_PREFIX + ACTOR_SCOPE
    if not geom_name.startswith(prefix):
        return -1
    head = geom_name[len(prefix):].split("/", 1)[0]
    return int(head) if head.isdigit() else -1


def segmentation_rows(geom_names, actors) -> list:
    """``(seg_id, geom_name, actor_id, kind, moving)`` per geom of a compiled model (``geom_names[g]`` is geom
    ``g``'s name; ``seg_id = g + 1``, the value the segmentation PNGs store). Static geoms: actor -1, kind
    ``static``, moving 0; a ``dyn/`` geom that belongs to no actor: actor -1, kind ``dynamic``."""
    by_id = {a.actor_id: a for a in actors}
    rows = []
    for g, name in enumerate(geom_names):
        a = by_id.get(actor_of_geom(name or ""))
        if a is not None:
            rows.append((g + 1, name, a.actor_id, a.kind, int(a.moving)))
        else:
            rows.append((g + 1, name or "", -1, "dynamic" if (name or "").startswith(GEOM_PREFIX) else "static", 0))
    return rows
