"""`firenav map check|show|convert|list`."""
from __future__ import annotations

import builtins
import json

import numpy as np
import pytest

from firenav_framework.building import bundled_plan, load_building
from firenav_framework.cli import main

from .test_check import CLOSED


def write_plan(tmp_path, *features, name="plan.geojson"):
    floor = {"type": "Feature", "geometry": None,
             "properties": {"kind": "floor", "floor": 0, "z": 0.0, "height": 3.0}}
    path = tmp_path / name
    path.write_text(json.dumps({"type": "FeatureCollection", "features": [floor, *features]}))
    return path


def test_check_clean_plan_exits_0(tmp_path, capsys):
    assert main(["map", "check", str(write_plan(tmp_path, *CLOSED))]) == 0
    assert "0 error(s), 0 warning(s)" in capsys.readouterr().out


def test_check_bundled_plan_by_name(capsys):
    assert main(["map", "check", "three_storey"]) == 0
    assert "three_storey: 3 floor(s)" in capsys.readouterr().out


def test_check_reports_problems_with_locations_and_exits_1(tmp_path, capsys):
    ghost = {"type": "Feature", "geometry": {"type": "LineString", "coordinates": [[1, 1.5], [1, 2.4]]},
             "properties": {"kind": "door", "floor": 0, "id": "ghost"}}
    assert main(["map", "check", str(write_plan(tmp_path, *CLOSED, ghost))]) == 1
    out = capsys.readouterr().out
    assert "error: floor 0 (1.00, 1.50) door ghost: jamb is 1.00 m from the nearest wall" in out
    assert "1 error(s)" in out


def test_check_warnings_alone_exit_0(tmp_path, capsys):
    inner = {"type": "Feature", "geometry": {"type": "LineString", "coordinates": [[1, 1.5], [3, 1.5]]},
             "properties": {"kind": "wall", "floor": 0, "id": "inner"}}
    assert main(["map", "check", str(write_plan(tmp_path, *CLOSED, inner))]) == 0
    assert "0 error(s), 2 warning(s)" in capsys.readouterr().out


def test_check_invalid_file_exits_2_with_the_reason(tmp_path, capsys):
    bad = tmp_path / "bad.geojson"
    bad.write_text('{"type": "FeatureCollection", "features": [{"type": "Feature", '
                   '"geometry": null, "properties": {"kind": "floor"}}]}')
    assert main(["map", "check", str(bad)]) == 2
    assert f"error: {bad}: feature 0: missing property 'floor'" in capsys.readouterr().err
    assert main(["map", "check", str(tmp_path / "none.geojson")]) == 2
    assert main(["map", "check", "no_such_bundled_plan"]) == 2


def test_check_real_aamks_export(shared_data, capsys):
    assert main(["map", "check", str(shared_data / "aamks" / "simple.static.json")]) == 0
    out = capsys.readouterr().out
    assert "note: Aamks units: centimetres" in out
    assert "note: floor 0: 2 wall(s) drawn twice merged" in out
    assert "[duplicate_wall]" not in out
    assert out.rstrip().endswith("1 floor(s), 9 wall segments, 2 doors: 0 error(s), 0 warning(s)")


def test_show_writes_one_png_per_floor(tmp_path, capsys):
    assert main(["map", "show", str(bundled_plan("three_storey")), "--out", str(tmp_path), "--dpi", "40"]) == 0
    pngs = sorted(tmp_path.glob("*.png"))
    assert [p.name for p in pngs] == [f"three_storey_floor{i}.png" for i in range(3)]
    assert all(p.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" for p in pngs)


def test_show_patterns_without_the_module_says_so(tmp_path, monkeypatch, capsys):
    real_import = builtins.__import__

    def fake_import(name, globals=None, locals=None, fromlist=(), level=0):
        if "search_patterns" in name or (fromlist and "search_patterns" in str(name)):
            raise ImportError("No module named 'firenav_framework.building.search_patterns'")
        return real_import(name, globals, locals, fromlist, level)
    monkeypatch.setattr(builtins, "__import__", fake_import)
    assert main(["map", "show", "flat_125", "--out", str(tmp_path), "--patterns"]) == 2
    assert "--patterns needs firenav_framework.building.search_patterns" in capsys.readouterr().err


def test_convert_aamks_to_native(shared_data, tmp_path, capsys):
    out = tmp_path / "simple.geojson"
    assert main(["map", "convert", str(shared_data / "aamks" / "simple.cad.json"), str(out)]) == 0
    a = load_building(shared_data / "aamks" / "simple.cad.json")
    b = load_building(out)
    np.testing.assert_allclose(b.floor(0).walls, a.floor(0).walls, atol=1e-4)
    assert [e.door for e in b.entrances] == [e.door for e in a.entrances]
    assert main(["map", "convert", "flat_125", str(tmp_path / "x.json")]) == 2


def test_list(capsys):
    assert main(["map", "list"]) == 0
    out = capsys.readouterr().out
    assert "office_loop" in out and "1100.0 m^2" in out
