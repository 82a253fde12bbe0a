"""The radios on the wire: breadcrumb_lines, the player's encoder, and the sensors
reading the frames back into the messages the simulator gives them."""
from __future__ import annotations

from collections import Counter

import pytest

from firenav_framework.codecs import FrameError, get_codec
from firenav_framework.codecs.breadcrumb_lines import RadioEvent, radio_event, radio_message
from firenav_framework.codecs.uwb_can import UwbCanCodec
from firenav_framework.messages import (BreadcrumbDrop, Range, RawFrame, RssiReading,
                                        TagDeployment, TagDetection)
from firenav_framework.testing.harness import Session
from firenav_framework.transports.player import DevicePlayer, Roster
from firenav_framework.transports.radio_frames import RadioEncoder, plan_anchors
from plugins.sensors.rfid_reader import RfidReaderSensor
from plugins.sensors.rssi_breadcrumb import RssiBreadcrumbSensor
from plugins.sensors.uwb import UwbSensor

from .all_sensors import simulation

FIELDS = {RssiReading: ("t", "agent", "device", "tx", "rx", "rssi_dbm"),
          BreadcrumbDrop: ("t", "agent", "device", "node_id"),
          Range: ("t", "agent", "device", "a", "b", "range_m", "sigma_m", "method", "nlos"),
          TagDetection: ("t", "agent", "device", "tag_id", "reader", "rssi_dbm", "reads"),
          TagDeployment: ("t", "agent", "device", "tag_id")}


def fields(msg) -> tuple:
    return (type(msg).__name__,) + tuple(getattr(msg, f) for f in FIELDS[type(msg)])


def frame(t: float, data: bytes, transport: str = "serial", channel="") -> RawFrame:
    return RawFrame(t=t, t_recv=t, transport=transport, channel=channel, data=data,
                    device="lines")


def encoder(sim) -> tuple[RadioEncoder, Roster]:
    roster = Roster.of_scenario(sim.scenario)
    return RadioEncoder(team=lambda: roster.order,
                        anchors=list(plan_anchors(sim.building))), roster


def test_every_radio_reading_and_drop_survives_its_line():
    sim = simulation()
    codec = get_codec("breadcrumb_lines")()
    team = [a.id for a in sim.scenario.model.agents]
    msgs = sim.messages["rssi"] + sim.messages["drops"]
    assert {m.agent for m in sim.messages["rssi"]} == {"ff3", ""} and len(msgs) > 1000
    for m in msgs:
        (f,) = codec.encode([radio_event(m, team)])
        (event,) = codec.decode(frame(m.t, f.data))
        assert fields(radio_message(event)) == fields(m)


@pytest.mark.parametrize("line, code", [
    (b"RSSI,bc1,ff3/radio,-6x", "bad_frames"),
    (b"RSSI,bc1,ff3/radio,nan", "bad_frames"),
    (b"RSSI,ff3/radio,ff3,-40", "bad_frames"),          # a radio hearing itself
    (b"RSSI,bc1,ff3/radio", "bad_frames"),
    (b"DROP,ff3,bc1", "bad_frames"),                     # no <agent>/<dispenser>
    (b"DROP,ff3/dispenser,bc 1", "bad_frames"),
    (b"RSSI,bc1,ff3/radio,-60.0*00", "checksum_errors"),
    (b"\xffRSSI", "bad_frames"),
])
def test_broken_radio_lines_are_frame_errors(line, code):
    with pytest.raises(FrameError) as err:
        get_codec("breadcrumb_lines")().decode(frame(1.0, line))
    assert err.value.code == code


def test_other_devices_lines_are_not_the_radios():
    codec = get_codec("breadcrumb_lines")()
    assert codec.decode(frame(1.0, b"TAG,ff1/rfid,E2,-50.0*4B")) is None
    assert codec.decode(frame(1.0, b"DROP,ff3/dispenser,bc1")) == [
        RadioEvent(1.0, "DROP", "ff3/dispenser", "bc1")]


def test_uwb_reports_carry_the_roster_position_and_the_plan_anchor_number():
    sim = simulation()
    enc, roster = encoder(sim)
    decoder = UwbCanCodec()
    seqs: dict[str, list[int]] = {}
    for r in sim.messages["uwb"]:
        link, frames = enc.encode(r)
        assert link == "can" and len(frames) == 1 and frames[0].channel == 0x380
        (rep,) = decoder.decode(frame(r.t, frames[0].data, "can", 0x380))
        assert roster.order[int(rep.tag) - 1] == r.agent
        assert plan_anchors(sim.building)[int(rep.anchor)] == r.b
        assert rep.range_m == r.range_m and rep.rx_dbm is None and rep.fp_dbm is None
        seqs.setdefault(rep.tag, []).append(rep.seq)
    for got in seqs.values():   # one counter per tag, no gaps: no report counted lost
        assert got == [i % 256 for i in range(len(got))]


def run_sensor(cls, params: dict, msgs) -> tuple[dict[str, list], dict]:
    """What a sensor published per port (diagnostics apart) on ``msgs``, and its counts."""
    session = Session(cls, params)
    out: dict[str, list] = {}
    for port, m in session.run(("in", m) for m in msgs).published:
        if port != "diagnostics":
            out.setdefault(port, []).append(fields(m))
    return out, dict(session.stats.counts.get(session.recorder.cid, {}))


@pytest.mark.parametrize("cls, kinds, params", [
    (UwbSensor, ("uwb",), {"tags": {"1": "ff1", "2": "ff2", "3": "ff3"},
                           "anchors": {"0": "base", "1": "uwb_entrance"}}),
    (RfidReaderSensor, ("rfid", "tags"), {}),
    (RssiBreadcrumbSensor, ("rssi", "drops"), {"rssi_1m_dbm": -46}),
])
def test_a_sensor_reads_the_frames_into_the_messages_it_reads_from_the_simulator(
        cls, kinds, params):
    sim = simulation()
    enc, _ = encoder(sim)
    msgs = sorted((m for k in kinds for m in sim.messages[k]), key=lambda m: m.t)
    frames = []
    for m in msgs:
        link, encoded = enc.encode(m)
        frames += [frame(m.t, f.data, "can" if link == "can" else "serial", f.channel)
                   for f in encoded]
    offline, _ = run_sensor(cls, params, msgs)
    live, counts = run_sensor(cls, params, frames)
    assert offline and live == offline
    assert not {"bad_frames", "bad_lines", "lost_reports", "other_lines"} & set(counts)


def test_the_player_counts_what_it_has_no_link_for():
    sim = simulation()
    enc, roster = encoder(sim)

    class Lines(list):
        def write(self, data: bytes) -> None:
            self.append(data)

    lines = Lines()
    player = DevicePlayer(lines=lines, speed=0, radio=enc)
    kinds = ("uwb", "rfid", "tags", "baro", "rssi", "drops")
    player.play((m for _, m in sim.stream(0.1, set(kinds))), roster)
    n = Counter(k for k in kinds for _ in sim.messages[k])
    assert player.skipped == {"can": n["uwb"]}          # no CAN bus given: UWB skipped
    assert len(lines) == player.sent["lines"] == n["rfid"] + n["tags"] + n["baro"] + \
        n["rssi"] + n["drops"]
    assert all(line.endswith(b"\n") and line.count(b"\n") == 1 for line in lines)
    assert sim.messages["baro"][0].data + b"\n" in lines   # frames already encoded: as they are
