"""GeoJSON plans from GIS tools: RFC 7946 (firenav's own export) and projected CRSs read
back into plan metres; degrees without a CRS refused."""
from __future__ import annotations

import json

import numpy as np
import pytest
from pyproj import Transformer

from firenav_framework.building import BuildingError, GeoRef, load_building
from firenav_framework.building.check import check_building
from firenav_framework.building.geojson_format import write_geojson
from firenav_framework.cli import main
from tests.building.aamks_exports import write_exports


def test_export_loads_back_as_the_same_plan(tmp_path):
    cad, _ = write_exports(tmp_path)
    plan = tmp_path / "plan.geojson"
    assert main(["map", "georef", str(cad), "--origin", "50.0614,19.9366,220", "--heading", "-20",
                 "--out", str(plan)]) == 0
    out = tmp_path / "gis.geojson"
    assert main(["map", "export", str(plan), str(out)]) == 0
    a, b = load_building(plan), load_building(out)
    assert (b.georef.lat, b.georef.lon, b.georef.alt, b.georef.bearing) == pytest.approx(
        (a.georef.lat, a.georef.lon, a.georef.alt, a.georef.bearing))
    assert [(f.z, f.height) for f in b.floors] == [(f.z, f.height) for f in a.floors]
    for fa, fb in zip(a.floors, b.floors):
        wa = np.sort(np.sort(fa.walls[~fa.wall_is_obstacle], axis=1).reshape(-1, 4), axis=0)
        wb = np.sort(np.sort(fb.walls[~fb.wall_is_obstacle], axis=1).reshape(-1, 4), axis=0)
        assert len(wb) <= len(wa)                      # collinear pieces joined by line_merge
        assert fb.outline.symmetric_difference(fa.outline).area < 1e-3
        for da, db in zip(fa.doors, fb.doors):
            assert da.id == db.id and np.allclose(da.center, db.center, atol=1e-4)
    for sa, sb in zip(a.stairs, b.stairs):
        assert sa.id == sb.id and sa.polygon.symmetric_difference(sb.polygon).area < 2e-3  # 0.1 mm
        assert np.allclose(sa.path, sb.path, atol=1e-4)
    assert [e.id for e in b.entrances] == [e.id for e in a.entrances]
    assert [str(p) for p in check_building(b) if p.severity == "error"] == []
    assert any("positions converted from WGS 84 (CRS84) to plan metres" in n for n in b.notes)


def test_qgis_style_file_in_a_projected_crs(tmp_path):
    # A 6 x 4 m hut drawn in UTM zone 34N, saved the way GIS tools do: one-part Multi*
    # geometries, the id on the Feature, a legacy crs member.
    truth = GeoRef(lat=50.0614, lon=19.9366, bearing=0.0)
    to_utm = Transformer.from_crs("OGC:CRS84", "EPSG:32634", always_xy=True)

    def utm(*pts):
        lonlat = truth.to_lonlat(np.array(pts, float))
        return [list(map(float, to_utm.transform(lo, la))) for lo, la in lonlat]

    feats = [
        {"type": "Feature", "properties": {"kind": "floor", "floor": 0, "z": 0, "height": 2.8},
         "geometry": None},
        {"type": "Feature", "id": "outer", "properties": {"kind": "wall", "floor": 0},
         "geometry": {"type": "MultiLineString", "coordinates": [utm((1, 0), (0, 0), (0, 4), (6, 4), (6, 0), (2, 0))]}},
        {"type": "Feature", "id": "front", "properties": {"kind": "door", "floor": 0},
         "geometry": {"type": "MultiLineString", "coordinates": [utm((2, 0), (1, 0))]}},
        {"type": "Feature", "id": "hut", "properties": {"kind": "room", "floor": 0, "name": "hut"},
         "geometry": {"type": "MultiPolygon", "coordinates": [[utm((0, 0), (6, 0), (6, 4), (0, 4), (0, 0))]]}},
    ]
    path = tmp_path / "hut.geojson"
    path.write_text(json.dumps({"type": "FeatureCollection", "features": feats,
                                "crs": {"type": "name", "properties": {"name": "urn:ogc:def:crs:EPSG::32634"}}}))
    b = load_building(path)
    f = b.floor(0)
    assert f.rooms[0].id == "hut" and f.rooms[0].polygon.area == pytest.approx(24.0, rel=1e-5)
    (d,) = f.doors
    assert d.id == "front" and d.width == pytest.approx(1.0, abs=1e-4)
    # The plan frame is East-North at the hut's centre; shapes are as drawn.
    assert np.allclose(f.rooms[0].polygon.centroid.coords[0], (0.0, 0.0), atol=1e-3)
    assert b.georef.to_lonlat(np.array([[0.0, 0.0]]))[0] == pytest.approx(
        truth.to_lonlat(np.array([[3.0, 2.0]]))[0], abs=1e-9)
    assert any("the file has no georef: plan frame East-North at" in n for n in b.notes)
    assert check_building(b) == []


def test_degrees_without_a_crs_are_refused(tmp_path):
    b_path = tmp_path / "plan.geojson"
    write_geojson(load_building(write_exports(tmp_path)[0]), b_path)
    doc = json.loads(b_path.read_text())
    g = GeoRef(lat=50.0614, lon=19.9366)
    for f in doc["features"]:
        geom = f["geometry"]
        if geom and geom["type"] == "LineString":
            geom["coordinates"] = g.to_lonlat(np.array(geom["coordinates"])).tolist()
        elif geom and geom["type"] == "Polygon":
            geom["coordinates"] = [g.to_lonlat(np.array(r)).tolist() for r in geom["coordinates"]]
        elif geom and geom["type"] == "Point":
            geom["coordinates"] = g.to_lonlat(np.array([geom["coordinates"]]))[0].tolist()
        if "footprint" in f["properties"]:
            f["properties"]["footprint"] = g.to_lonlat(np.array(f["properties"]["footprint"])).tolist()
    b_path.write_text(json.dumps(doc))
    with pytest.raises(BuildingError, match="look like longitude/latitude degrees"):
        load_building(b_path)
    doc["crs"] = {"type": "name", "properties": {"name": "EPSG:999999"}}
    b_path.write_text(json.dumps(doc))
    with pytest.raises(BuildingError, match="unknown crs 'EPSG:999999'"):
        load_building(b_path)
    doc["crs"] = {"type": "name", "properties": {"name": "urn:ogc:def:crs:OGC:1.3:CRS84"}}
    b_path.write_text(json.dumps(doc))
    b = load_building(b_path)
    assert [str(p) for p in check_building(b) if p.severity == "error"] == []
