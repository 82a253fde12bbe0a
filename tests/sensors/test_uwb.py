"""The uwb sensor: frame codecs, bias calibration, NLOS flags, outliers and dropouts."""
from __future__ import annotations

import math

import numpy as np
import pytest

from firenav_framework import Range, RawFrame, Tick
from firenav_framework.codecs import FrameError
from firenav_framework.codecs.twr_report import TwrReport
from firenav_framework.codecs.uwb_can import UwbCanCodec
from firenav_framework.codecs.uwb_lines import UwbLinesCodec
from firenav_framework.testing import check_plugin, make_component
from firenav_plugins.sensors.uwb import UwbSensor
from firenav_plugins.sensors.uwb.bias import AnchorBias

MAP = {"tags": {"1": "ff1", "2": "ff2"}, "anchors": {"1": "uwb_start"}}


def encode_uwb_line(report: TwrReport, checksum: bool = True) -> bytes:
    [frame] = UwbLinesCodec({"checksum": checksum}).encode([report])
    return frame.data


def decode_uwb_line(data: bytes, t: float = 0.0):
    reports = UwbLinesCodec().decode(RawFrame(t=t, transport="serial", channel="", data=data))
    return None if reports is None else reports[0]


def decode_uwb_can(frame_id, data, t: float = 0.0):
    reports = UwbCanCodec().decode(RawFrame(t=t, transport="can", channel=frame_id, data=data))
    return None if reports is None else reports[0]


def line_frame(t, report, **kw) -> RawFrame:
    return RawFrame(t=t, transport="serial", channel="", data=encode_uwb_line(report, **kw),
                    device="/dev/ttyUSB0")


def can_frame(t, report) -> RawFrame:
    [f] = UwbCanCodec().encode([report._replace(t=t)])
    assert f.t == t
    return RawFrame(t=t, transport="can", channel=f.channel, data=f.data, device="can0")


def feed(params, items):
    comp, rec, stats = make_component(UwbSensor, params)
    for stream, msg in items:
        comp.handle(stream, msg)
    return rec, stats.counts.get("under_test", {})


# -- codecs ---------------------------------------------------------------------------

def test_text_line_round_trip_and_format():
    r = TwrReport(0.0, "1", "uwb_start", 12.345, -81.5, -84.0, 17)
    line = encode_uwb_line(r)
    assert line.startswith(b"RANGE,1,uwb_start,12345,-81.5,-84.0,17*")
    assert decode_uwb_line(line) == r
    assert decode_uwb_line(encode_uwb_line(r, checksum=False)) == r
    # optional fields: no powers, no sequence number, a failed exchange
    assert decode_uwb_line(b"RANGE,3,7,,,") == TwrReport(0.0, "3", "7", None)
    assert decode_uwb_line(b"RANGE,3,7,-1,-90,-95\r\n") == TwrReport(0.0, "3", "7", None, -90.0, -95.0)
    assert decode_uwb_line(b"$GPGGA,foo") is None          # another device's line


@pytest.mark.parametrize("data, code", [
    (b"RANGE,1,1,5000,-80.0,-82.0,3*00", "checksum_errors"),
    (b"RANGE,1,1,5000", "bad_frames"),
    (b"RANGE,1,1,five,-80,-82", "bad_frames"),
    (b"RANGE,1,1,-5000,-80,-82", "bad_frames"),
    (b"RANGE,1,1,5000,-80,-82,300", "bad_frames"),
    (b"RANGE,1,1,5000,nan,-82", "bad_frames"),
    (b"RANGE,1,a b,5000,-80,-82", "bad_frames"),
    (b"RANGE,\xff,1,5000,-80,-82", "bad_frames"),
])
def test_broken_text_lines_raise_a_counted_error(data, code):
    with pytest.raises(FrameError) as err:
        decode_uwb_line(data)
    assert err.value.code == code


def test_can_frame_round_trip_follows_the_dbc():
    r = TwrReport(0.0, "2", "1", 23.456, -92.5, -99.0, 250)
    [f] = UwbCanCodec().encode([r])
    assert f.channel == 0x380 and len(f.data) == 8
    # little-endian layout of docs/formats/uwb.md: tag, anchor, range (24 bit), powers, seq
    assert f.data[0] == 2 and f.data[1] == 1
    assert int.from_bytes(f.data[2:5], "little") == 23456
    assert f.data[5] == int((-92.5 + 128) / 0.5) and f.data[7] == 250
    assert decode_uwb_can(f.channel, f.data) == r
    [failed] = UwbCanCodec().encode([TwrReport(0.0, "2", "1", None)])
    assert decode_uwb_can(failed.channel, failed.data) == TwrReport(0.0, "2", "1", None, None, None, 0)
    assert decode_uwb_can(0x100, f.data) is None             # an IMU frame on the same bus
    with pytest.raises(FrameError):
        decode_uwb_can(0x380, f.data[:5])


# -- conditioning ---------------------------------------------------------------------

def test_decoded_ranges_become_range_messages_with_node_ids():
    rec, counts = feed(MAP, [("raw", line_frame(1.0, TwrReport(0.0, "1", "1", 4.0, -80, -81, 0))),
                             ("raw", can_frame(1.5, TwrReport(0.0, "2", "1", 6.0, -80, -81, 0))),
                             ("raw", line_frame(2.0, TwrReport(0.0, "9", "4", 3.0, -80, -81)))])
    out = rec.on("range")
    assert [(m.agent, m.a, m.b, m.range_m, m.nlos, m.sigma_m) for m in out] == [
        ("ff1", "ff1", "uwb_start", 4.0, False, 0.1),
        ("ff2", "ff2", "uwb_start", 6.0, False, 0.1),
        ("tag9", "tag9", "anchor4", 3.0, False, 0.1)]
    assert out[0].device == "ff1/uwb" and out[0].method == "uwb"


def test_bias_calibration_constant_scale_and_power_table():
    bias = AnchorBias(offset_m=0.10, scale=1.01, power_table=[(-95.0, 0.20), (-75.0, 0.0)])
    # measured = scale * true + offset + b(rx): invert it
    assert bias.correct(1.01 * 10.0 + 0.10 + 0.10, -85.0) == pytest.approx(10.0)
    assert bias.correct(1.01 * 10.0 + 0.10 + 0.20, -120.0) == pytest.approx(10.0)   # held
    assert bias.correct(1.01 * 10.0 + 0.10, None) == pytest.approx(10.0)
    rec, _ = feed({**MAP, "bias": {"uwb_start": {"offset_m": 0.25}, "*": {"scale": 1.02}}},
                  [("raw", line_frame(1.0, TwrReport(0.0, "1", "1", 5.25, -80, -81))),
                   ("raw", line_frame(1.0, TwrReport(0.0, "1", "7", 5.10, -80, -81)))])
    assert [m.range_m for m in rec.on("range")] == pytest.approx([5.0, 5.0])


def test_first_path_power_well_below_total_power_flags_nlos():
    rec, counts = feed(MAP, [("raw", line_frame(1.0, TwrReport(0.0, "1", "1", 5.0, -80.0, -85.9))),
                             ("raw", line_frame(2.0, TwrReport(0.0, "1", "1", 5.1, -80.0, -86.1))),
                             ("raw", line_frame(3.0, TwrReport(0.0, "1", "1", 5.2, -80.0, None)))])
    assert [(m.nlos, m.sigma_m) for m in rec.on("range")] == [(False, 0.1), (True, 0.5),
                                                              (False, 0.1)]
    assert counts["nlos_suspect"] == 1


def test_impossible_range_jumps_are_dropped_until_the_link_relocks():
    t = np.arange(10.0)
    truth = 5.0 + 1.0 * t                       # walking away at 1 m/s
    reports = [TwrReport(0.0, "1", "1", float(r), -80, -81) for r in truth]
    reports[3] = TwrReport(0.0, "1", "1", 40.0, -80, -81)        # a multipath blunder
    items = [("raw", line_frame(float(tk), r)) for tk, r in zip(t, reports)]
    rec, counts = feed(MAP, items)
    assert [m.range_m for m in rec.on("range")] == [r for k, r in enumerate(truth) if k != 3]
    assert counts["outliers"] == 1
    # a real jump (the tag was moved to another anchor's label): three consistent
    # reports re-lock the link
    jump = [("raw", line_frame(10.0 + k, TwrReport(0.0, "1", "1", 60.0 + 0.1 * k, -80, -81)))
            for k in range(4)]
    rec, counts = feed(MAP, items + jump)
    assert [m.range_m for m in rec.on("range")][-2:] == pytest.approx([60.2, 60.3])
    assert counts["outliers"] == 3 and counts["relocks"] == 1


def test_running_ranges_are_not_outliers():
    """Issue 15: at a run (4 m/s away from the anchor in a stride, 2-3 s gaps where the
    direct path is lost) the old 3 m/s bound dropped good ranges as outliers. The default
    bound is a running human with margin (6 m/s): none is dropped; a multipath blunder
    still is."""
    t = np.array([0.0, 1.0, 2.0, 4.5, 5.5, 8.0, 9.0])
    truth = 5.0 + 4.0 * t
    items = [("raw", line_frame(float(tk), TwrReport(0.0, "1", "1", float(r), -80, -81)))
             for tk, r in zip(t, truth)]
    rec, counts = feed(MAP, items)
    assert [m.range_m for m in rec.on("range")] == pytest.approx(truth)
    assert "outliers" not in counts
    _, counts = feed({**MAP, "gate": {"max_speed": 3.0}}, items)
    assert counts["outliers"] >= 1                # the old bound
    blunder = [("raw", line_frame(10.0, TwrReport(0.0, "1", "1", 80.0, -80, -81)))]
    _, counts = feed(MAP, items + blunder)
    assert counts["outliers"] == 1


def test_dropouts_failures_and_lost_reports_are_reported():
    items = [("raw", line_frame(1.0, TwrReport(0.0, "1", "1", 5.0, -80, -81, 10))),
             ("raw", line_frame(1.2, TwrReport(0.0, "1", "1", None, None, None, 11))),
             ("raw", line_frame(1.4, TwrReport(0.0, "1", "1", 5.1, -80, -81, 14))),
             ("tick", Tick(t=3.0, period=1.0)),
             ("tick", Tick(t=5.0, period=1.0)),
             ("tick", Tick(t=6.0, period=1.0)),
             ("raw", line_frame(6.5, TwrReport(0.0, "1", "1", 8.0, -80, -81, 15)))]
    rec, counts = feed(MAP, items)
    assert counts["ranging_failed"] == 1 and counts["lost_reports"] == 2
    diags = rec.on("diagnostics")
    assert [(d.code, d.level, d.active, d.t) for d in diags] == [
        ("uwb_silent", "warning", True, 5.0), ("uwb_silent", "info", False, 6.5)]
    assert "uwb_start" in diags[0].text and "ff1" in diags[0].text


def test_bad_frames_are_counted_not_raised():
    items = [("raw", RawFrame(t=1.0, transport="serial", channel="", data=b"RANGE,1,1,x,,")),
             ("raw", RawFrame(t=1.0, transport="serial", channel="", data=b"HELLO")),
             ("raw", RawFrame(t=1.0, transport="can", channel="0x380", data=b"\0" * 8)),
             ("raw", RawFrame(t=1.0, transport="mavlink", channel=331, data=b"\0" * 8)),
             ("rng", Range(t=1.0, agent="ff1", a="ff1", b="x", range_m=math.nan, sigma_m=0.1)),
             ("rng", Range(t=1.0, agent="ff1", a="ff1", b="x", range_m=500.0, sigma_m=0.1)),
             ("rng", Range(t=1.0, agent="ff1", a="ff1", b="x", range_m=5.0, sigma_m=0.1,
                           method="rssi"))]
    rec, counts = feed(MAP, items)
    assert rec.on("range") == []
    assert counts == {"bad_frames": 2, "other_frames": 2, "non_finite": 1, "out_of_range": 1,
                      "not_uwb": 1}


def test_simulated_ranges_pass_through_calibration_and_keep_their_flags():
    rng = Range(t=2.0, agent="ff1", device="sim", a="ff1", b="uwb_start", range_m=7.3,
                sigma_m=0.3, nlos=True)
    rec = check_plugin(UwbSensor, {"bias": {"*": {"offset_m": 0.3}}}, sample_input=[("r", rng)])
    (out,) = rec.on("range")
    assert out.range_m == pytest.approx(7.0) and out.nlos and out.sigma_m == 0.5
    assert out.device == "ff1/uwb"


def test_bad_dbc_path_fails_at_construction(tmp_path):
    dbc = tmp_path / "x.dbc"
    dbc.write_text('VERSION ""\n\nBU_: A\n\nBO_ 1 OTHER: 8 A\n SG_ X : 0|8@1+ (1,0) [0|255] "" A\n')
    with pytest.raises(ValueError, match="no UWB_TWR_REPORT"):
        make_component(UwbSensor, {"frames": {"codec_options": {"uwb_can": {"dbc": "x.dbc"}}}},
                       base_dir=tmp_path)


@pytest.mark.parametrize("jump, flagged", [(1.0, True), (-1.0, False), (0.1, False)])
def test_range_jumping_longer_than_its_track_is_nlos_suspect(jump, flagged):
    """No power readings (simulated ranges): walking away at 1.2 m/s, ranges every 0.5 s;
    from t = 10 s a wall adds delay (positive jump). Only a longer jump is NLOS-like."""
    t = np.arange(0.0, 15.0, 0.5)
    r = 3.0 + 1.2 * t + np.where(t >= 10.0, jump, 0.0)
    items = [("r", Range(t=float(tk), agent="ff1", a="ff1/uwb", b="uwb_start",
                         range_m=float(rk), sigma_m=0.1)) for tk, rk in zip(t, r)]
    rec, counts = feed({}, items)
    out = rec.on("range")
    assert len(out) == len(t)
    assert not any(m.nlos for m in out if m.t < 10.0)
    assert out[int(np.searchsorted(t, 10.0))].nlos == flagged
