"""Top-down map of a scene: object footprints, route and GCP labels (matplotlib)."""
from __future__ import annotations

import numpy as np

COLORS = {"building": "0.55", "wall": "0.4", "tree": "forestgreen", "hedge": "darkgreen",
          "furniture": "peru", "decor": "orchid", "path": "wheat", "ground": "none", "ceiling": "none"}


def plot_topdown(scene, ax, route_xy=None, gcps=None):
    """Draw ``scene``'s footprints, its route (or ``route_xy`` (N, 2)) and GCP labels on ``ax``."""
    from matplotlib.patches import Circle, Polygon
    for fp in scene.footprints():
        color = COLORS.get(fp.category, "0.7")
        if color == "none":
            continue
        if fp.radius > 0 and fp.category != "path":
            ax.add_patch(Circle(fp.center_xy, fp.radius, color=color, alpha=0.6, lw=0))
        elif fp.category != "path":
            ax.add_patch(Polygon(fp.corners_xy(), closed=True, color=color, alpha=0.7, lw=0))
    xy = np.asarray(route_xy if route_xy is not None else scene.route.xy, float)
    if route_xy is None and scene.route.closed:
        xy = np.vstack([xy, xy[:1]])
    ax.plot(xy[:, 0], xy[:, 1], "b-", lw=1.5, label="route")
    ax.plot(xy[0, 0], xy[0, 1], "bo", ms=5)
    for g in (gcps if gcps is not None else scene.gcp_sites):
        ax.plot(g.x, g.y, "r^", ms=6)
        ax.annotate(g.name, (g.x, g.y), textcoords="offset points", xytext=(4, 4), fontsize=8, color="r")
    xmin, xmax, ymin, ymax = scene.extent_xy()
    ax.set_xlim(xmin, xmax)
    ax.set_ylim(ymin, ymax)
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_title(f"{scene.name} (seed {scene.config.seed})")
    return ax
