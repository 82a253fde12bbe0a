"""Damaged or empty field logs: reading resumes after the damage, the damage is counted
and reported, one device's bad file costs only that device."""
from __future__ import annotations

import json

import numpy as np
import pytest

from firenav_framework.cli import main

from tests.hardening.logs import damage, write_can_log, write_tlog
from tests.hardening.pipelines import ins_on_recording, poses, run_text


def replay(path) -> str:
    return f"""
sources: [{{id: rec, plugin: recording, path: "{path}"}}]
sensors:
  - {{id: imu, plugin: foot_imu, input: rec.raw, axes: [x, -y, -z],
     frames: {{agent_map: {{"sys1/*": ff1, "sys2/*": ff2, "*node1*": ff1, "*node2*": ff2}}}}}}
estimators: [{{id: ins, plugin: zupt_ins, input: imu.imu}}]
"""


def write_log(sim_folder, path):
    if path.suffix == ".tlog":
        return write_tlog(sim_folder, path)
    return write_can_log(sim_folder, path, max_container=16384 if path.suffix == ".blf" else None)


@pytest.mark.timeout(120)
@pytest.mark.parametrize("suffix, counted", [
    (".tlog", {"bad_tlog_records": 1, "skipped_bytes": 4096}),
    (".log", {"damaged_regions": 1}),
    (".blf", {"damaged_regions": 1}),
    (".asc", {}),     # python-can skips lines it does not recognise itself
    (".trc", {}),
])
def test_damage_in_the_middle_of_a_log_costs_only_the_damaged_part(sim_folder, tmp_path,
                                                                    suffix, counted):
    clean = tmp_path / f"clean{suffix}"
    write_log(sim_folder, clean)
    damaged = tmp_path / f"damaged{suffix}"
    damaged.write_bytes(clean.read_bytes())
    damage(damaged, 4096)
    ref = run_text(replay(clean), tmp_path / "a")
    res = run_text(replay(damaged), tmp_path / "b")
    assert min(poses(ref).values()) >= 20 and set(poses(ref)) == {"ff1", "ff2"}
    # before: reading ended at the damage for every device (5 of 16 poses kept)
    assert poses(res) == poses(ref)
    assert res.stats.messages["rec.raw"] >= 0.9 * ref.stats.messages["rec.raw"]
    rec = res.stats.counts.get("rec", {})
    for what, n in counted.items():
        assert rec.get(what) == n, (what, rec)
    if counted:
        (warning,) = [d for d in res.diagnostics if d.component == "rec"]
        assert warning.code == "damaged_log" and str(damaged) in warning.text


def test_a_tlog_damaged_in_several_places_resumes_after_each(sim_folder, tmp_path):
    path = tmp_path / "x.tlog"
    n = write_tlog(sim_folder, path)
    for at in (0.2, 0.5, 0.8):
        damage(path, 500, at=at, seed=int(at * 10))
    res = run_text(replay(path), tmp_path / "o")
    assert res.stats.counts["rec"]["bad_tlog_records"] == 3
    assert res.stats.messages["rec.raw"] >= n - 6        # at most the torn records
    assert min(poses(res).values()) >= 20


@pytest.mark.parametrize("name", ["can-0000-x.log", "can-0000-x.asc", "mav-0000-x.tlog",
                                  "serial-0000-x.lines"])
def test_an_empty_log_is_reported_and_the_run_exits_1(tmp_path, capsys, caplog, name):
    log = tmp_path / name
    log.write_bytes(b"" if not name.endswith(".asc") else
                    b"date Mon Jan 1 00:00:00.000 am 2024\nbase hex  timestamps absolute\n")
    pipeline = tmp_path / "p.yaml"
    pipeline.write_text(replay(log))
    assert main(["run", str(pipeline), "--quiet", "--output", str(tmp_path / "o")]) == 1
    # before: 0 poses, no word, exit 0
    assert any("empty" in r.getMessage() and str(log) in r.getMessage() for r in caplog.records)
    assert "error: no source delivered any data" in capsys.readouterr().err


def test_streams_jsonl_without_its_header_is_refused(sim_copy, tmp_path, capsys):
    streams = sim_copy / "streams.jsonl"
    streams.write_text("".join(streams.read_text().splitlines(keepends=True)[1:]))
    pipeline = tmp_path / "p.yaml"
    pipeline.write_text(ins_on_recording(streams))
    assert main(["run", str(pipeline), "--quiet", "--output", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert "p.yaml:5: cannot set up 'rec'" in err and "the first line is not its header" in err


@pytest.mark.parametrize("damage_kind", ["empty", "garbage header", "garbage"])
def test_one_firefighters_bad_imu_file_costs_only_him(sim_folder, sim_copy, tmp_path,
                                                     damage_kind):
    csv = sim_copy / "imu_ff1.csv"
    if damage_kind == "empty":
        csv.write_bytes(b"")
    elif damage_kind == "garbage header":
        csv.write_bytes(bytes(range(256)) * 16 + csv.read_bytes())
    else:
        damage(csv, 4096)
    clean = run_text(ins_on_recording(sim_folder / "streams.jsonl"), tmp_path / "clean")
    res = run_text(ins_on_recording(sim_copy / "streams.jsonl"), tmp_path / "bad")
    # before: the whole recording source failed: 0 poses for both, exit 0
    ff2, ff2_clean = res.tracks["ins.pose"]["ff2"], clean.tracks["ins.pose"]["ff2"]
    np.testing.assert_array_equal(ff2.position, ff2_clean.position)
    assert res.stats.messages["rec.uwb"] == clean.stats.messages["rec.uwb"]
    if damage_kind == "garbage":
        # damage inside the data costs only the rows it hit (counted), not the file
        assert "unreadable_files" not in res.stats.counts["rec"]
        assert 0 < res.stats.counts["rec"]["bad_rows"] < 200
        assert len(res.tracks["ins.pose"]["ff1"]) > 0.9 * len(clean.tracks["ins.pose"]["ff1"])
        return
    assert res.stats.counts["rec"]["unreadable_files"] == 1
    (warning,) = [d for d in res.diagnostics if d.code == "unreadable_file"]
    assert str(csv) in warning.text and "the other files go on" in warning.text


def test_radio_records_with_binary_garbage_are_counted_not_fatal(sim_folder, sim_copy, tmp_path):
    streams = sim_copy / "streams.jsonl"
    lines = streams.read_bytes().splitlines(keepends=True)
    streams.write_bytes(b"".join(lines[:20]) + bytes(range(128, 256)) * 8 + b"\n" +
                        b"".join(lines[20:]))
    clean = run_text(ins_on_recording(sim_folder / "streams.jsonl"), tmp_path / "clean")
    res = run_text(ins_on_recording(streams), tmp_path / "bad")
    assert res.stats.counts["rec"]["bad_rows"] == 1
    assert res.stats.messages["rec.uwb"] + res.stats.messages["rec.rssi"] == \
        clean.stats.messages["rec.uwb"] + clean.stats.messages["rec.rssi"]
    assert json.loads(lines[0])["format"] == "firenav-sim-streams"
