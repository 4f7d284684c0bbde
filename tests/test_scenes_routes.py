"""Routes, GCPs and the registry of the campus and indoor scenes (no rendering)."""
import numpy as np
import pytest
from scipy.interpolate import CubicSpline

from scenes import SceneConfig, SceneError, make_scene, scene_names
from scenes.routes import distance_to_polyline
from sim.rng import scene_streams


def spline_length(wp, closed):
    """Length of a C2 cubic spline through the waypoints (periodic for closed routes)."""
    if closed:
        wp = np.vstack([wp, wp[:1]])
    s = np.concatenate([[0], np.cumsum(np.linalg.norm(np.diff(wp, axis=0), axis=1))])
    cs = CubicSpline(s, wp, bc_type="periodic" if closed else "not-a-knot")
    q = np.linspace(0, s[-1], 20001)
    return float(np.linalg.norm(np.diff(cs(q), axis=0), axis=1).sum())


def test_campus_route_length_and_shape():
    sc = make_scene(SceneConfig(name="campus"), scene_streams(0))
    r = sc.route
    assert r.closed and r.cruise_speed_mps == 1.2 and r.accel_mps2 == 0.4
    L = spline_length(r.xy, True)
    assert 88.0 <= L <= 92.0
    # prediction: offset curve at 4.5 m of an 18.5 x 12.5 m footprint = 2 (18.5 + 12.5) + 2 pi 4.5;
    # 2 m waypoint spacing on 4.5 m arcs: spline error well below 5 cm
    assert L == pytest.approx(62.0 + 9.0 * np.pi, abs=0.05)
    assert np.linalg.norm(r.xy[0] - r.xy[-1]) < 2.5          # the start is near the end


def test_indoor_route_length_and_open():
    sc = make_scene(SceneConfig(name="indoor"), scene_streams(0))
    r = sc.route
    assert not r.closed and r.cruise_speed_mps == 0.8
    L = spline_length(r.xy, False)
    assert 20.0 <= L <= 22.0
    # prediction: legs 5.2 + 3.75 + 5.75 + 3.95 + 4.0 m minus four 90-degree corners of radius 1,
    # (2 - pi/2) m each; 0.75 m waypoint spacing on 1 m arcs: spline error below 5 cm
    assert L == pytest.approx(22.65 - 4 * (2 - np.pi / 2), abs=0.05)


@pytest.mark.parametrize("name,expected", [("campus", [f"C0{k}" for k in range(1, 8)]),
                                           ("indoor", ["P01", "P02", "P03"])])
def test_gcps_on_route(name, expected):
    sc = make_scene(SceneConfig(name=name), scene_streams(0))
    g = sc.gcp_sites
    assert [s.name for s in g] == expected
    d = distance_to_polyline([(s.x, s.y) for s in g], sc.path_xy, closed=sc.route.closed)
    assert np.all(d < 0.01)                                  # rounded to mm, on the centre line
    assert np.all(sc.ground_height([s.x for s in g], [s.y for s in g]) == 0.0)


def test_indoor_p03_near_white_wall():
    sc = make_scene(SceneConfig(name="indoor"), scene_streams(0))
    p3 = sc.gcp_sites[2]
    fps = {f.name: f for f in sc.footprints()}
    white = [f for n, f in fps.items() if n.startswith("static/wall/north_n2")]
    dmin = min(distance_to_polyline([(p3.x, p3.y)], f.corners_xy(), closed=True)[0] for f in white)
    # the north wall's inner face is at y = 12, P03 at y = 10.2: 1.8 m (paper: "less than 2 m")
    assert dmin == pytest.approx(1.8, abs=1e-6)


def test_registry_and_unknown_scene():
    assert {"campus", "indoor"} <= set(scene_names()) and list(scene_names()) == sorted(scene_names())
    with pytest.raises(SceneError) as e:
        make_scene(SceneConfig(name="x"), scene_streams(0))
    assert str(e.value).startswith(f"unknown scene 'x'; valid: {', '.join(scene_names())}") and "\n" not in str(e.value)


def test_plot_topdown_runs():
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from scenes.plot import plot_topdown
    fig, ax = plt.subplots()
    sc = make_scene(SceneConfig(name="indoor"), scene_streams(0))
    plot_topdown(sc, ax)
    assert len(ax.patches) > 50 and ax.get_title() == "indoor (seed 0)"
    plt.close(fig)


def test_scene_draws_from_the_streams_it_receives():
    """Same factory -> same layout; another seed's factory -> another layout (campus trees)."""
    def trees(seed):
        fps = make_scene(SceneConfig(name="campus"), scene_streams(seed)).footprints()
        return [f.center_xy for f in fps if f.name.startswith("static/tree")]
    assert trees(0) == trees(0) and trees(0) != trees(1)
    with pytest.raises(SceneError, match="streams must be a callable"):
        make_scene(SceneConfig(name="campus"), 0)
