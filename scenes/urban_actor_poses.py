"""Every urban actor's pose at one time in one batched pass: the renderer's dynamic state each frame.

:meth:`scenes.urban_actors.Actor.poses` evaluates one actor at a time; a scene of hundreds of actors then
spends far more CPU per frame in small numpy calls than the renderer spends drawing (urban-dynamic, 462
actors: 11.4 CPU ms per frame on the 2-core machine). :class:`ActorPoser` evaluates the same expressions for
all actors at once, grouped by their number of modulation terms and their motion law, element for element in
the same order, so the poses are bit for bit those of ``Actor.poses`` (``tests/test_scenes_urban.py``).
"""
from __future__ import annotations

import numpy as np


class ActorPoser:
    """``actors`` (:class:`scenes.urban_actors.Actor`, any order) posed at one time by :meth:`at`; ``t_ref_ns``:
    the time origin of their motion (:data:`scenes.urban_actors.T_REF_NS`)."""

    def __init__(self, actors, t_ref_ns: int):
        self.actors = actors
        self.t_ref = np.int64(t_ref_ns)
        self.names = [a.body_name for a in actors]
        self.origin = np.array([np.asarray(a.origin_xy) for a in actors], float).reshape(-1, 2)
        self.d = np.array([[np.cos(a.heading), np.sin(a.heading)] for a in actors], float).reshape(-1, 2)
        self.base = np.tile(np.eye(4), (len(actors), 1, 1))
        for i, (c, sn) in enumerate(self.d):
            self.base[i, :2, :2] = [[c, -sn], [sn, c]]
        groups: dict = {}
        for i, a in enumerate(actors):
            if a.moving:
                law = "from rest" if a.mode == "line" and a.start_tau > 0 else a.mode
                groups.setdefault((len(a.amp), law), []).append(i)
        self.groups = []
        for (_, law), idx in groups.items():
            sel = [actors[i] for i in idx]
            terms = [np.array([getattr(a, f) for a in sel], float).T for f in ("amp", "omega", "phase")]  # (K, G)
            speed = np.array([a.speed for a in sel], float)
            tau = np.array([a.start_tau for a in sel], float)
            self.groups.append((np.array(idx), law, *terms, speed, tau))

    def arcs(self, t_ns: int) -> np.ndarray:
        """(A,) arc length ``s`` of every actor at ``t_ns`` (:meth:`scenes.urban_actors.Actor.arc`)."""
        t = (np.asarray(t_ns, np.int64).reshape(-1) - self.t_ref).astype(float) * 1e-9      # (1,)
        s_all = np.zeros(len(self.names))
        for idx, law, a, w, p, speed, tau in self.groups:
            arg = w * t[None] + p
            s = (a * np.sin(arg)).sum(0)
            if law == "from rest":                                  # v (t - tau (1 - e^(-t/tau)))
                tp = np.maximum(t, 0.0)
                e = np.exp(-tp / tau)
                s = s + speed * (tp - tau * (1 - e))
            elif law == "line":
                s = s + speed * t
            s_all[idx] = s
        return s_all

    def at(self, t_ns: int) -> dict:
        """``{body name: (4,4) T_w_actor}`` at ``t_ns``: as ``{a.body_name: a.poses([t_ns])[0]}``."""
        T = self.base.copy()
        T[:, :2, 3] = self.origin + self.arcs(t_ns)[:, None] * self.d
        return dict(zip(self.names, T))
