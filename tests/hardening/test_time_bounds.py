"""Bounded work whatever the timestamps: one bad value never makes the timeline emit
ticks or hold data without bound, and one device's clock never costs another's data."""
from __future__ import annotations

import json

import numpy as np
import pytest

from firenav_framework.messages import Diagnostic, GroundTruth, RawFrame, Range, Tick
from firenav_framework.time_merge import merge_in_time
from firenav_framework.timeline import Timeline, TimelineConfig

from tests.hardening.pipelines import ins_on_recording, poses, run_text


def frame(t: float, device: str = "sys1/comp1") -> RawFrame:
    """A raw frame as the tlog reader makes it: ``t`` = ``t_recv`` = the record's stamp."""
    return RawFrame(t=t, t_recv=t, device=device, transport="mavlink", channel=105,
                    data=b"%.6f" % t)


def run_timeline(tl: Timeline, items) -> list:
    out = []
    for stream, msg in items:
        tl.push(stream, msg)
        out += tl.release()
    return out + tl.release(flush=True)


@pytest.mark.timeout(30)
def test_a_flipped_byte_in_a_tlog_stamp_is_dropped_and_the_ticks_stay_bounded():
    # the case: a stamp of 1.8e13 s among 100 Hz frames, with 10 Hz ticks
    # (before: one tick per 0.1 s up to 1.8e13 s, MemoryError after minutes)
    tl = Timeline()
    tl.add_tick(0.1, "ticks.0.1")
    times = [1000.0 + 0.01 * i for i in range(300)]
    items = [("mav.raw", frame(t)) for t in times]
    items.insert(150, ("mav.raw", frame(1.8e13)))
    items.insert(200, ("mav.raw", frame(times[199] + 1e5)))  # a smaller leap: 1e5 s
    out = run_timeline(tl, items)
    data = [m.t for _, m in out if isinstance(m, RawFrame)]
    ticks = [m.t for _, m in out if isinstance(m, Tick)]
    assert data == times                                   # every good frame, in order
    assert len(ticks) == 30 and max(ticks) <= times[-1]    # 3 s of 10 Hz ticks
    assert tl.stats.counts["timeline"]["implausible_time"] == 2
    diag = [m for _, m in out if isinstance(m, Diagnostic) and m.code == "implausible_time"]
    assert len(diag) == 1 and "sys1/comp1" in diag[0].text   # reported once per device
    assert all(m.t <= times[-1] for _, m in out)           # nothing carries the bad time


def test_a_real_leap_of_every_device_is_used_after_confirmation_and_its_ticks_skipped():
    # a recording paused for two hours: every device continues 7200 s later
    tl = Timeline()
    tl.add_tick(0.1, "ticks.0.1")
    before = [10.0 + 0.01 * i for i in range(100)]
    after = [7210.0 + 0.01 * i for i in range(100)]
    items = [("s", frame(t, d)) for t in before + after for d in ("a", "b")]
    out = run_timeline(tl, items)
    data = [m.t for _, m in out if isinstance(m, RawFrame)]
    ticks = [m.t for _, m in out if isinstance(m, Tick)]
    assert data == sorted(2 * (before + after))            # nothing lost
    assert len(ticks) == 20                                # 1 s before, 1 s after
    assert tl.stats.counts["timeline"]["ticks_skipped"] == pytest.approx(71990, abs=2)
    assert tl.stats.counts["timeline"]["time_leaps"] == 1  # the others follow the first
    assert "implausible_time" not in tl.stats.counts["timeline"]


def test_an_event_far_in_the_future_is_dropped_when_its_channel_comes_back():
    tl = Timeline()
    rng = [("uwb", Range(t=t, agent="ff1", device="ff1/uwb", a="ff1/uwb", b="base",
                         range_m=3.0, sigma_m=0.1)) for t in (1.0, 1e308, 2.0, 3.0)]
    truth = [("truth", GroundTruth(t=0.5 * i, agent="ff1", position=np.zeros(3)))
             for i in range(8)]
    items = sorted(rng + truth, key=lambda sm: 0.0 if sm[1].t > 1e300 else sm[1].t)
    out = run_timeline(tl, items)
    assert [m.t for s, m in out if s == "uwb"] == [1.0, 2.0, 3.0]
    assert len([m for s, m in out if s == "truth"]) == 8
    assert tl.stats.counts["timeline"]["implausible_time"] == 1


def test_what_is_still_held_at_the_end_is_dropped_and_counted():
    tl = Timeline()
    out = run_timeline(tl, [("s", frame(1.0)), ("s", frame(2.0)), ("s", frame(1e9))])
    assert [m.t for _, m in out if isinstance(m, RawFrame)] == [1.0, 2.0]
    assert tl.stats.counts["timeline"]["implausible_time"] == 1


def test_the_lead_limit_is_a_documented_timeline_setting():
    cfg = TimelineConfig()
    assert cfg.max_lead == 3600.0 and cfg.lead_confirm == 3
    with pytest.raises(ValueError):
        TimelineConfig(max_lead=0)


def test_a_merge_puts_a_jumped_input_where_its_data_belong():
    a = [0.0, 1.0, 2.0, -997.0, -996.0]           # a device clock reset of 1000 s back
    b = [0.5, 1.5, 2.5, 3.5, 4.5]
    out = list(merge_in_time([a, b], time_of=float, jump_back=5.0, max_lead=3600.0))
    assert out == [0.0, 0.5, 1.0, 1.5, 2.0, 2.5, -997.0, 3.5, -996.0, 4.5]
    c = [1e308, 1.0, 2.0, 3.0]                     # a corrupt first stamp
    out = list(merge_in_time([c, b], time_of=float, jump_back=5.0, max_lead=3600.0))
    assert out == [0.5, 1e308, 1.0, 1.5, 2.0, 2.5, 3.0, 3.5, 4.5]


# -- whole runs on a recording of two firefighters ----------------------------------------

def insert_records(path, records: dict[int, dict]) -> None:
    lines = path.read_text().splitlines(keepends=True)
    for at in sorted(records, reverse=True):
        lines.insert(at, json.dumps(records[at]) + "\n")
    path.write_text("".join(lines))


@pytest.mark.timeout(60)
def test_one_bad_time_in_streams_jsonl_costs_only_that_record(sim_folder, sim_copy, tmp_path):
    clean = run_text(ins_on_recording(sim_folder / "streams.jsonl"), tmp_path / "clean")
    bad = {"port": "uwb", "type": "range", "agent": "ff1", "device": "ff1/uwb",
           "a": "ff1/uwb", "b": "uwb_entrance", "range_m": 1.0, "sigma_m": 0.1}
    insert_records(sim_copy / "streams.jsonl", {3: {**bad, "t": 1e308},
                                                30: {**bad, "t": 1.8e13}})
    res = run_text(ins_on_recording(sim_copy / "streams.jsonl"), tmp_path / "bad")
    # before: the radio messages after the bad one came after all the IMU data and were
    # dropped as late (455 in the run)
    for stream in ("rec.uwb", "rec.rssi", "imu.imu"):
        assert res.stats.messages[stream] == clean.stats.messages[stream], stream
    assert res.stats.counts["timeline"]["implausible_time"] == 2
    assert poses(res) == poses(clean)


@pytest.mark.timeout(60)
def test_one_firefighters_clock_jumping_back_does_not_cost_another_his_track(
        sim_folder, sim_copy, tmp_path):
    csv = sim_copy / "imu_ff1.csv"
    lines = csv.read_text().splitlines(keepends=True)
    body = [i for i, line in enumerate(lines) if line[:1].isdigit()]
    for i in body[len(body) // 2:]:            # from half-way on, ff1's clock is 1000 s back
        t, rest = lines[i].split(",", 1)
        lines[i] = f"{float(t) - 1000.0:.6f},{rest}"
    csv.write_text("".join(lines))
    clean = run_text(ins_on_recording(sim_folder / "streams.jsonl"), tmp_path / "clean")
    res = run_text(ins_on_recording(sim_copy / "streams.jsonl"), tmp_path / "jump")
    assert res.stats.counts["timeline"]["clock_jumps"] == 1
    assert "late_dropped" not in res.stats.counts["timeline"]
    ff2, ff2_clean = res.tracks["ins.pose"]["ff2"], clean.tracks["ins.pose"]["ff2"]
    np.testing.assert_array_equal(ff2.t, ff2_clean.t)      # ff2 keeps every pose
    np.testing.assert_array_equal(ff2.position, ff2_clean.position)
