"""rfid_reader: debouncing into passes, deployments, reader lines, bad input."""
from __future__ import annotations

import pytest

from firenav_framework import RawFrame, TagDeployment, TagDetection, Tick
from firenav_framework.codecs import FrameError
from firenav_framework.codecs.rfid_lines import RfidEvent, RfidLinesCodec
from firenav_framework.testing import check_plugin, make_component
from firenav_plugins.sensors.rfid_reader import RfidReaderSensor
from tests.contract.known import known


def encode_rfid_line(event: RfidEvent, checksum: bool = True) -> bytes:
    [frame] = RfidLinesCodec({"checksum": checksum}).encode([event])
    return frame.data


def decode_rfid_line(data: bytes, t: float = 0.0) -> RfidEvent | None:
    events = RfidLinesCodec().decode(RawFrame(t=t, transport="serial", channel="", data=data))
    return None if events is None else events[0]


def reader(**params):
    comp, rec, stats = make_component(RfidReaderSensor, params)
    comp.start()
    return comp, rec, lambda: stats.counts.get("under_test", {})


def read(t, tag="T1", rssi=-50.0, reads=1, agent="ff1"):
    return TagDetection(t=t, agent=agent, device=f"{agent}/rfid", tag_id=tag,
                        reader=f"{agent}/rfid", rssi_dbm=rssi, reads=reads)


def deploy(t, tag="T1", agent="ff1"):
    return TagDeployment(t=t, agent=agent, device=f"{agent}/rfid", tag_id=tag)


def test_a_burst_of_reads_is_one_detection_at_the_peak():
    """Reads 5 a second while walking past: one detection, all reads counted, at the
    time of the strongest read; it comes out once the reads have stopped for pass_gap."""
    comp, rec, counts = reader()
    comp.handle("tags", deploy(9.0))
    rssi = [-60, -55, -50, -46, -44, -47, -52, -58]
    for k, r in enumerate(rssi):
        comp.handle("rfid", read(10.0 + 0.2 * k, rssi=r))
    comp.handle("tick", Tick(t=12.5, period=0.5))
    assert rec.on("detections") == []              # not over yet (last read at 11.4)
    comp.handle("tick", Tick(t=13.5, period=0.5))
    (det,) = rec.on("detections")
    assert det.t == pytest.approx(10.8) and det.rssi_dbm == -44 and det.reads == len(rssi)
    assert det.agent == "ff1" and det.tag_id == "T1" and det.reader == "ff1/rfid"
    assert counts()["reads"] == len(rssi)


def test_separate_passes_and_readers_stay_apart():
    comp, rec, _ = reader(pass_gap=2.0)
    comp.handle("tags", deploy(0.0))
    for t in (10.0, 10.5, 11.0):                    # pass 1
        comp.handle("rfid", read(t))
    for t in (20.0, 20.3):                          # pass 2 (back through the door)
        comp.handle("rfid", read(t))
    comp.handle("rfid", read(20.1, agent="ff2"))    # ff2 at the same tag
    comp.finish()
    dets = rec.on("detections")
    assert [(d.agent, d.reads) for d in dets] == [("ff1", 3), ("ff1", 2), ("ff2", 1)]


def test_standing_at_a_tag_is_cut_into_max_pass_pieces():
    comp, rec, _ = reader(max_pass=5.0)
    comp.handle("tags", deploy(0.0))
    for k in range(25):                             # 12 s of reads, every 0.5 s
        comp.handle("rfid", read(1.0 + 0.5 * k))
    comp.finish()
    dets = rec.on("detections")
    assert len(dets) == 3 and sum(d.reads for d in dets) == 25


def test_unknown_tags_are_passed_on_counted_and_reported_once():
    comp, rec, counts = reader(known_tags=["SURVEYED"])
    for t, tag in ((1.0, "X"), (10.0, "X"), (20.0, "SURVEYED")):
        comp.handle("rfid", read(t, tag=tag, reads=2))
    comp.finish()
    assert [d.tag_id for d in rec.on("detections")] == ["X", "X", "SURVEYED"]
    assert counts()["unknown_tag_reads"] == 4
    warn = [d for d in rec.on("diagnostics") if d.code == "unknown_tag"]
    assert len(warn) == 1 and "X" in warn[0].text


def test_duplicate_tag_ids_are_counted_and_the_first_placement_stands():
    comp, rec, counts = reader()
    comp.handle("tags", deploy(5.0, "T9", "ff1"))
    comp.handle("tags", deploy(50.0, "T9", "ff3"))
    comp.finish()
    assert [(d.agent, d.t) for d in rec.on("deployments")] == [("ff1", 5.0)]
    assert counts()["duplicate_tag_deployments"] == 1
    (warn,) = [d for d in rec.on("diagnostics") if d.code == "duplicate_tag_id"]
    assert "ff3" in warn.text and "ff1" in warn.text


def test_a_reset_firefighter_s_tags_stay_on_their_doors_for_everyone_else():
    """reset('ff1') (the restart fault policy) forgets ff1's open passes, not the tags
    ff1 stuck on doors: ff2's later read of one is a read of a deployed tag, and ff1
    deploying it again is a duplicate."""
    comp, rec, counts = reader()
    comp.handle("tags", deploy(5.0, "T4", "ff1"))
    comp.handle("rfid", read(6.0, tag="T4", agent="ff1"))     # ff1's pass still open
    comp.reset("ff1")
    comp.handle("rfid", read(30.0, tag="T4", agent="ff2"))
    comp.handle("tags", deploy(40.0, "T4", "ff1"))
    comp.finish()
    assert [(d.agent, d.t) for d in rec.on("detections")] == [("ff2", 30.0)]
    assert "unknown_tag_reads" not in counts()
    assert counts()["duplicate_tag_deployments"] == 1
    assert [d.agent for d in rec.on("deployments")] == ["ff1"]


def test_reader_lines_round_trip_and_drive_the_same_chain():
    lines = [RfidEvent(0.0, "DEPLOY", "ff2/rfid", "E2AA"),
             RfidEvent(0.0, "TAG", "ff2/rfid", "E2AA", -48.5, 3),
             RfidEvent(0.0, "TAG", "ff2/rfid", "E2AA", None)]
    for line in lines:
        assert decode_rfid_line(encode_rfid_line(line)) == line
        assert decode_rfid_line(encode_rfid_line(line, checksum=False) + b"\r\n") == line
    comp, rec, counts = reader()
    frames = [RawFrame(t=1.0 + k, transport="serial", channel="", data=encode_rfid_line(l),
                       device="/dev/ttyUSB0") for k, l in enumerate(lines)]
    frames.append(RawFrame(t=4.0, transport="serial", channel="", data=b"RANGE,1,2,3000,,",
                           device="/dev/ttyUSB0"))
    for f in frames:
        comp.handle("raw", f)
    comp.finish()
    (dep,) = rec.on("deployments")
    (det,) = rec.on("detections")
    assert dep.agent == det.agent == "ff2" and det.reads == 4 and det.rssi_dbm == -48.5
    assert counts()["other_lines"] == 1


@pytest.mark.parametrize("line, what", [
    (b"TAG,ff1/rfid,E2AA,-40.0*00", "checksum"),
    (b"TAG,ff1/rfid,E2AA", "fields"),
    (b"TAG,ff1/rfid,E2 AA,-40", "bad reader or tag id"),
    (b"TAG,ff1/rfid,E2AA,loud", "non-numeric"),
    (b"TAG,ff1/rfid,E2AA,-40,0", "out of range"),
    (b"DEPLOY,ff1/rfid", "fields"),
    (b"TAG,\xff\xfe", "ASCII"),
])
def test_broken_lines_are_named(line, what):
    with pytest.raises(FrameError, match=what):
        decode_rfid_line(line)


def test_bad_input_is_counted_not_fatal():
    comp, rec, counts = reader(readers={"R7": "ff4"})
    comp.handle("raw", RawFrame(t=1.0, transport="serial", channel="", data=b"TAG,x,y,zz"))
    comp.handle("raw", RawFrame(t=1.1, transport="serial", channel="", data=b"TAG,x,y,zz"))
    comp.handle("raw", RawFrame(t=1.2, transport="can", channel=0x100, data=b"\x00"))
    comp.handle("rfid", TagDetection(t=float("nan"), agent="ff1", tag_id="T"))
    comp.handle("rfid", TagDetection(t=2.0, agent="", device="", tag_id="T"))
    comp.handle("raw", RawFrame(t=3.0, transport="udp", channel="", data=b"TAG,R7,E2BB,-41"))
    comp.finish()
    c = counts()
    assert c["bad_lines"] == 2 and c["frames_not_lines"] == 1 and c["bad_reads"] == 2
    assert len([d for d in rec.on("diagnostics") if d.code == "rfid_bad_line"]) == 1
    (det,) = rec.on("detections")
    assert det.agent == "ff4" and det.tag_id == "E2BB"


def test_a_read_older_than_its_pass_is_counted_and_leaves_the_pass_alone():
    """Reader lines carry the reader's own times: a late line older than the pass's
    last read would move the pass's peak back in time; it is skipped and counted."""
    comp, rec, counts = reader()
    comp.handle("tags", deploy(1.0))
    for t, rssi in ((10.0, -60), (10.4, -50), (10.8, -55)):
        comp.handle("rfid", read(t, rssi=rssi))
    comp.handle("rfid", read(10.2, rssi=-30))            # stronger, but from the past
    comp.finish()
    (det,) = rec.on("detections")
    assert det.t == pytest.approx(10.4) and det.rssi_dbm == -50 and det.reads == 3
    assert counts()["out_of_order_reads"] == 1
    assert [d.code for d in rec.on("diagnostics")] == ["rfid_out_of_order"]


def test_is_a_conforming_plugin():
    check_plugin(RfidReaderSensor, sample_input=[("tags", deploy(0.0)), ("rfid", read(1.0)),
                                                 ("rfid", read(1.2))],
                 exclude=known("sensor", "rfid_reader"))
