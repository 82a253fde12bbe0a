"""Georeference: plan metres <-> WGS84 (checked against geodesics), control-point fits,
`firenav map georef` / `map export`, and RFC 7946 GeoJSON for plans and track files."""
from __future__ import annotations

import json
import math
import shutil

import numpy as np
import pytest
from pyproj import Geod

from firenav_framework.building import GeoRef, bundled_plan, load_building
from firenav_framework.building.georef import fit_control_points
from firenav_framework.building.gis_export import gis_geojson
from firenav_framework.cli import main
from firenav_framework.messages import PoseEstimate
from firenav_framework.sinks.track_files import GeoJsonTracks
from firenav_framework.testing import run_component

GEOD = Geod(ellps="WGS84")
WARSAW = dict(lat=52.2297, lon=21.0122)


@pytest.mark.parametrize("bearing", [0.0, 30.0, -120.0])
def test_plan_points_land_at_the_right_distance_and_azimuth(bearing):
    g = GeoRef(bearing=bearing, alt=110.0, **WARSAW)
    # Plan +y is `bearing` clockwise from north, plan +x 90 degrees further.
    for xy, dist, az in (((0.0, 100.0), 100.0, bearing), ((250.0, 0.0), 250.0, bearing + 90.0),
                         ((-30.0, -40.0), 50.0, bearing + 180.0 + math.degrees(math.atan2(-30, -40)) - 180.0)):
        lon, lat, h = g.to_wgs84(np.array([xy]))[0]
        fwd, _, d = GEOD.inv(WARSAW["lon"], WARSAW["lat"], lon, lat)
        # Geodesic on the ellipsoid, 110 m below the tangent plane: shorter by 110/R.
        assert d == pytest.approx(dist * (1 - 110.0 / 6.371e6), abs=1e-3)
        assert (fwd - az + 180) % 360 - 180 == pytest.approx(0.0, abs=1e-3)
        assert h == pytest.approx(110.0 + dist ** 2 / (2 * 6.37e6), abs=2e-3)  # Earth curves away


def test_round_trip_and_anchor():
    g = GeoRef.at_point((12.0, -3.0), bearing=77.0, alt=5.0, **WARSAW)
    assert g.to_wgs84(np.array([[12.0, -3.0, 0.0]]))[0] == pytest.approx([WARSAW["lon"], WARSAW["lat"], 5.0])
    pts = np.random.default_rng(1).uniform(-500, 500, (50, 3))
    np.testing.assert_allclose(g.from_wgs84(g.to_wgs84(pts)), pts, atol=1e-6)
    np.testing.assert_allclose(g.from_lonlat(g.to_lonlat(pts[:, :2])), pts[:, :2], atol=1e-3)
    # Heading east on a plan turned 90 degrees clockwise points south.
    assert math.degrees(g.heading_to_azimuth(0.0)) == pytest.approx(90.0 + 77.0)


@pytest.mark.parametrize("bad", [dict(lat=91.0, lon=0.0), dict(lat=0.0, lon=float("nan")),
                                 dict(lat=0.0, lon=0.0, bearing=400.0)])
def test_bad_georef_values(bad):
    with pytest.raises(ValueError, match="georef"):
        GeoRef(**bad)


def test_control_points_recover_the_georef():
    truth = GeoRef.at_point((0.0, 0.0), bearing=-35.0, alt=0.0, **WARSAW)
    plan = np.array([[0.0, 0.0], [40.0, 0.0], [40.0, 15.0], [3.0, 16.0]])
    surveyed = truth.to_lonlat(plan)
    fit = fit_control_points(plan, surveyed)
    assert fit.residuals.max() < 1e-3 and fit.scale == pytest.approx(1.0, abs=1e-6)
    assert fit.georef.bearing == pytest.approx(-35.0, abs=1e-3)
    np.testing.assert_allclose(fit.georef.to_lonlat(plan), surveyed, atol=1e-8)
    # A plan drawn 1 % too small: the fit says so and leaves residuals at the ends.
    stretched = fit_control_points(plan * 0.99, surveyed)
    assert stretched.scale == pytest.approx(1 / 0.99, rel=1e-4)
    assert 0.1 < stretched.residuals.max() < 0.3


@pytest.fixture
def native_copy(tmp_path):
    path = tmp_path / "corridor.geojson"
    shutil.copy(bundled_plan("corridor"), path)
    return path


def test_map_georef_writes_the_georef_into_a_native_plan(native_copy, capsys):
    before = native_copy.read_text().splitlines()
    assert main(["map", "georef", str(native_copy), "--origin", "52.2297,21.0122,110.5",
                 "--heading", "30"]) == 0
    out = capsys.readouterr().out
    assert "plan +y 30.00 deg clockwise from true north" in out
    after = native_copy.read_text().splitlines()
    # Every other feature untouched; the bundled plan's georef replaced by the new one.
    assert [ln for ln in after if '"georef"' not in ln] == [ln for ln in before if '"georef"' not in ln]
    assert sum('"georef"' in ln for ln in after) == 1
    b = load_building(native_copy)
    assert (b.georef.lat, b.georef.lon, b.georef.alt, b.georef.bearing) == (52.2297, 21.0122, 110.5, 30.0)
    # Again with control points: replaces the georef, does not add a second one.
    pts = b.georef.to_lonlat(np.array([[0.0, 0.0], [40.0, 0.0], [40.0, 15.9]]))
    args = ["map", "georef", str(native_copy)]
    for (x, y), (lon, lat) in zip([(0, 0), (40, 0), (40, 15.9)], pts):
        args += ["--control", f"{x},{y},{float(lat)!r},{float(lon)!r}"]
    assert main(args) == 0
    assert "plan scale agrees with the points" in capsys.readouterr().out
    again = load_building(native_copy)
    assert again.georef.bearing == pytest.approx(30.0, abs=1e-3)   # tangent plane 27 m away
    np.testing.assert_allclose(again.georef.to_lonlat(np.array([[10.0, 5.0]])),
                               b.georef.to_lonlat(np.array([[10.0, 5.0]])), atol=1e-9)


def test_map_georef_refusals(native_copy, tmp_path, capsys, shared_data):
    aamks = shared_data / "aamks" / "simple.static.json"
    assert main(["map", "georef", str(aamks), "--origin", "52,21", "--heading", "0"]) == 2
    assert "give --out OUT.geojson" in capsys.readouterr().err
    assert main(["map", "georef", "corridor", "--origin", "52,21", "--heading", "0"]) == 2
    assert main(["map", "georef", str(native_copy), "--origin", "52", "--heading", "0"]) == 2
    assert "--origin must be 2 or 3 numbers" in capsys.readouterr().err
    assert main(["map", "georef", str(native_copy), "--origin", "95,21", "--heading", "0"]) == 2
    assert "georef lat must be a number within +-90" in capsys.readouterr().err
    assert main(["map", "georef", str(native_copy), "--control", "0,0,52.0,21.0",
                 "--control", "40,0,52.0,21.01"]) == 2        # 40 m on the plan, 684 m apart
    assert "do not fit one turn and shift" in capsys.readouterr().err
    # An Aamks export georeferenced into a new native plan.
    out = tmp_path / "simple.geojson"
    assert main(["map", "georef", str(aamks), "--origin=-33.92,18.42", "--heading", "90",
                 "--out", str(out)]) == 0
    assert load_building(out).georef.lat == -33.92


def _ring_area_lonlat(ring):
    x, y = np.asarray(ring)[:, 0], np.asarray(ring)[:, 1]
    return 0.5 * np.sum(x[:-1] * y[1:] - x[1:] * y[:-1])


def test_export_is_rfc7946_when_georeferenced(native_copy, tmp_path):
    assert main(["map", "georef", str(native_copy), "--origin", "52.2297,21.0122,100",
                 "--heading", "45"]) == 0
    out = tmp_path / "gis.geojson"
    assert main(["map", "export", str(native_copy), str(out)]) == 0
    doc = json.loads(out.read_text())
    b = load_building(native_copy)
    assert "crs" not in doc and doc["coordinate_frame"]["frame"] == "WGS84"
    for f in doc["features"]:
        g = f["geometry"]
        if g["type"] == "Polygon":
            assert _ring_area_lonlat(g["coordinates"][0]) > 0          # counter-clockwise
        pos = np.array(g["coordinates"] if g["type"] != "Point" else [g["coordinates"]],
                       dtype=object)
        flat = np.array([p for ring in (pos if g["type"] == "Polygon" else [pos]) for p in ring], float)
        assert np.all(np.abs(flat[:, 0] - 21.0122) < 0.01) and np.all(np.abs(flat[:, 1] - 52.2297) < 0.01)
    doors = {f["properties"]["id"]: f for f in doc["features"] if f["properties"]["kind"] == "door"}
    for d in b.doors:
        (lon0, lat0, _), (lon1, lat1, _) = doors[d.id]["geometry"]["coordinates"]
        assert GEOD.inv(lon0, lat0, lon1, lat1)[2] == pytest.approx(d.width, abs=1e-3)


def _without_georef(path):
    doc = json.loads(path.read_text())
    doc["features"] = [f for f in doc["features"] if f["properties"]["kind"] != "georef"]
    path.write_text(json.dumps(doc))
    return path


def test_export_says_local_without_georef(native_copy, tmp_path, capsys):
    out = tmp_path / "local.geojson"
    assert main(["map", "export", str(_without_georef(native_copy)), str(out)]) == 0
    assert "not WGS84" in capsys.readouterr().out
    doc = json.loads(out.read_text())
    assert doc["coordinate_frame"]["frame"] == "local" and "NOT WGS84" in doc["coordinate_frame"]["note"]
    b = load_building(native_copy)
    anchor = next(f for f in doc["features"] if f["properties"]["kind"] == "anchor")
    assert anchor["geometry"]["coordinates"] == pytest.approx(b.anchors[0].position.tolist())
    assert gis_geojson(b)["features"][0]["properties"]["kind"] == "floor"


def _poses():
    for k in range(5):
        yield "pf.pose", PoseEstimate(t=float(k), agent="ff1", position=np.array([2.0 * k, 1.0, 0.0]),
                                      heading=0.0, cov=np.eye(4) * 0.04, floor=0, trusted=True)


def test_geojson_tracks_are_wgs84_with_a_georeferenced_building(tmp_path):
    b = load_building(bundled_plan("corridor"))
    b.georef = GeoRef(bearing=10.0, alt=100.0, **WARSAW)
    run_component(GeoJsonTracks, {}, _poses(), building=b, output_dir=tmp_path)
    doc = json.loads((tmp_path / "tracks.geojson").read_text())
    assert doc["coordinate_frame"]["frame"] == "WGS84"
    coords = np.array(doc["features"][0]["geometry"]["coordinates"])
    want = b.georef.to_wgs84(np.array([[2.0 * k, 1.0, 0.0] for k in range(5)]))
    np.testing.assert_allclose(coords, want, atol=1e-8)
    assert GEOD.inv(*coords[0, :2], *coords[-1, :2])[2] == pytest.approx(8.0, abs=1e-3)


def test_geojson_tracks_say_local_without_georef(tmp_path, native_copy):
    run_component(GeoJsonTracks, {}, _poses(), building=load_building(_without_georef(native_copy)),
                  output_dir=tmp_path)
    doc = json.loads((tmp_path / "tracks.geojson").read_text())
    assert doc["coordinate_frame"]["frame"] == "local"
    assert doc["features"][0]["geometry"]["coordinates"][-1] == [8.0, 1.0, 0.0]
