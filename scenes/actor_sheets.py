"""Every urban actor wears an atlas of its own, packed into shared sheets.

Each actor ``k`` of ``kind`` has its own atlas (:func:`actor_look`: stream ``texture/urban-actor/<kind>/<k>``, a
car's laid out for its body, a bus's with its own window bays, doors, livery, advert and wear), so no two cars,
buses or pedestrians look alike: two standing traffic cars that wore one atlas matched 19 inliers on their
rears in two places 500 m apart (``vo-testbed validate places``, ``urban-static`` seed 2). With a skybox MuJoCo
takes at most 999 materials and the urban scene's surfaces use about 670, so the atlases of :data:`PER_SHEET`
consecutive actors of a kind are tiled into one texture, a *sheet* (``cols x rows`` atlases, row 0 at the top),
with one material; an actor's mesh maps into its own tile (:func:`sheet_uv`). The texture memory is that of
one atlas per actor.
"""
from __future__ import annotations

import numpy as np

from scenes.actor_textures import LAYOUTS, actor_atlas, bus_atlas, car_atlas, car_layout
from scenes.bus_shapes import bus_layout

PER_SHEET = {"car": (4, 2), "bus": (4, 2), "pedestrian": (4, 4)}     # (cols, rows) of atlases per sheet


def actor_look(builder, kind: str, actor_id: int, shape) -> np.ndarray:
    """The ``(H, W, 3) uint8`` atlas of actor ``actor_id`` of ``kind`` (stream ``texture/urban-actor/<kind>/<k>``), laid
    out for its body ``shape`` (a car's arches, :func:`scenes.actor_textures.car_layout`; a bus's
    :func:`scenes.bus_shapes.bus_layout`); through the builder's texture store, keyed by the states of the streams
    it depends on (the body's stream ``urban/actor-shape/<k>`` too)."""
    keys = (f"texture/urban-actor/{kind}/{actor_id}", f"urban/actor-shape/{actor_id}")

    def draw():
        rng = builder.streams(keys[0])
        if kind == "car":
            return car_atlas(rng, car_layout(rng, shape.arches()))
        return bus_atlas(rng, bus_layout(rng, shape)) if kind == "bus" else actor_atlas(kind, rng)
    return builder.textures.get(tuple(builder.streams(k) for k in keys), ("actor", kind), draw)


def sheet_uv(kind: str, uv, tile: tuple) -> list:
    """Texture coordinates ``uv`` (flat list u0, v0, u1, ...) of one atlas mapped into ``tile`` = (col, row) of a
    ``kind`` sheet."""
    cols, rows = PER_SHEET[kind]
    a = np.asarray(uv, float).reshape(-1, 2)
    return ((a + np.asarray(tile, float)) / [cols, rows]).ravel().tolist()


def add_sheets(builder, actors, shapes: dict, specular: dict) -> dict:
    """Draw every actor's atlas, tile them into sheets and add one material per sheet
    (``mat/actor/<kind>/sheet<j>``); ``shapes``: actor id -> body (None for a pedestrian). Returns actor id ->
    (material name, tile (col, row))."""
    out, by_kind = {}, {}
    for a in actors:
        by_kind.setdefault(a.kind, []).append(a)
    for kind, group in by_kind.items():
        cols, rows = PER_SHEET[kind]
        (W, H), _ = LAYOUTS[kind]
        n = cols * rows
        for j in range(0, len(group), n):
            sheet = np.zeros((rows * H, cols * W, 3), np.uint8)
            members = group[j:j + n]
            for p, a in enumerate(members):
                c, r = p % cols, p // cols
                sheet[r * H:(r + 1) * H, c * W:(c + 1) * W] = actor_look(builder, kind, a.actor_id, shapes[a.actor_id])
            mat = builder.image_material(f"actor/{kind}/sheet{j // n}", sheet, specular=specular[kind])
            for p, a in enumerate(members):
                out[a.actor_id] = (mat, (p % cols, p // cols))
    return out
