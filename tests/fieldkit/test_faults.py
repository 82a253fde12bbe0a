"""Faults on live links, one live run of field-live.yaml per case (tests/fieldkit/harness.py).

Each case ends with every other firefighter's track equal to the offline run (the
end-to-end tolerance) and the fault counted in the run summary. Faults start 3 s into
the scenario, when everyone walks.
"""
from __future__ import annotations

import dataclasses
import re

import can
import numpy as np

from firenav_framework.summary import format_summary
from firenav_framework.transports.mavlink_link import mavutil
from firenav_framework.transports.player import DevicePlayer

from .harness import assert_others_intact, offline_tracks, run_live, send_as_is


FAULT_T = 3.0  # s of scenario time


def summary_has(run, component: str, what: str, n: int | None = None) -> bool:
    text = format_summary(run.result)
    return (f"  {component}: {what} {n}" if n is not None else f"  {component}: {what} ") in text


def assert_track_continues(run, agent: str, after: float) -> None:
    """The faulted firefighter's track goes on: poses from before the fault to later than
    ``after`` (scenario time), all in order."""
    live, offline = run.tracks()[agent], offline_tracks()[agent]
    offset = live.t[0] - offline.t[0]  # the first step comes before every fault
    assert np.all(np.diff(live.t) > 0)
    assert live.t[-1] - offset > after, f"{agent}: last pose at {live.t[-1] - offset:.2f} s"


class Corrupter:
    """ff1 (CAN): every 4th sample's ACCEL frame cut to 5 bytes, an error frame every 10
    samples; ff3 (MAVLink): every 4th packet with a broken CRC, every 4th+2 cut short."""

    def __init__(self):
        self.n = {"can_cut": 0, "error_frames": 0, "crc": 0, "mav_cut": 0}
        self.k = {"ff1": 0, "ff3": 0}

    def __call__(self, player: DevicePlayer, block, link: str, frames: list) -> None:
        if block.agent not in self.k or not FAULT_T <= block.t < FAULT_T + 1.5:
            return send_as_is(player, block, link, frames)
        k = self.k[block.agent]
        self.k[block.agent] += 1
        if link == "can":
            if k % 4 == 0:  # frames of one sample: ACCEL, GYRO, TIME
                frames = [frames[0]._replace(data=frames[0].data[:5])] + frames[1:]
                self.n["can_cut"] += 1
            if k % 10 == 0:
                player.can_bus.send(can.Message(is_error_frame=True))
                player.sent["can"] += 1
                self.n["error_frames"] += 1
        elif k % 4 == 0:
            data = frames[0].data
            frames = [frames[0]._replace(data=data[:-1] + bytes([data[-1] ^ 0xFF]))] + frames[1:]
            self.n["crc"] += 1
        elif k % 4 == 2:
            frames = [frames[0]._replace(data=frames[0].data[:20])] + frames[1:]
            self.n["mav_cut"] += 1
        player.transmit(link, frames)


def test_corrupt_and_truncated_frames(tmp_path):
    fault = Corrupter()
    run = run_live(tmp_path, tamper=fault)
    n = fault.n
    assert min(n.values()) > 0
    assert run.count("can", "decode_errors") == n["error_frames"]
    assert run.count("imu_can", "bad_frames") == n["can_cut"]
    assert run.count("imu_can", "incomplete_samples") == n["can_cut"]
    assert run.count("mav", "decode_errors") == n["crc"] + n["mav_cut"]
    assert run.result.stats.counts["mav"]["frames"] == run.sent["mavlink"]
    assert summary_has(run, "imu_can", "bad_frames", n["can_cut"])
    assert_others_intact(run, {"ff1", "ff3"})
    for agent in ("ff1", "ff3"):  # a quarter of 1.5 s of samples lost: the walk goes on
        assert_track_continues(run, agent, after=FAULT_T + 2.5)
        live, offline = run.tracks()[agent], offline_tracks()[agent]
        assert len(live) == len(offline), f"{agent}: a step was lost"


class Unplug:
    """ff2's CAN node sends nothing from FAULT_T for ``seconds`` (cable out, then back)."""

    def __init__(self, seconds: float):
        self.window = (FAULT_T, FAULT_T + seconds)

    def __call__(self, player, block, link, frames) -> None:
        if block.agent == "ff2" and self.window[0] <= block.t < self.window[1]:
            return
        player.transmit(link, frames)


def test_device_unplugged_and_back_is_stale_then_recovers(tmp_path):
    run = run_live(tmp_path, speed=1.0, tamper=Unplug(3.5))  # silent_after is 2 s
    assert_others_intact(run, {"ff2"})
    # the commander is told, naming the firefighter; the condition clears when it is back
    silent = [d for d in run.result.diagnostics if d.code == "device_silent"
              and d.component == "can" and d.agent == "ff2"]
    raised = [d for d in silent if d.active]
    cleared = [d for d in silent if not d.active]
    assert {d.device for d in raised} == {"can0/0x130", "can0/0x131", "can0/0x132"}
    assert {d.device for d in cleared} == {d.device for d in raised}
    assert max(d.t for d in raised) < min(d.t for d in cleared)
    # ... and the ground station is told (local clock, never epoch seconds), then told
    # it is over; the page latches the alarm until someone acknowledges it
    texts = [m.text for m in run.gcs if m.get_type() == "STATUSTEXT" and m.text.startswith("ff2")]
    raised = [k for k, t in enumerate(texts) if t.startswith("ff2 DEVICE SILENT since ")]
    assert raised and any(t.startswith("ff2 device silent over at ") for t in texts[raised[0]:])
    assert not [t for t in texts if re.search(r"\d{9}", t)], "UNIX seconds in a STATUSTEXT"
    sysid = next(m.get_srcSystem() for m in run.gcs if m.get_type() == "STATUSTEXT"
                 and m.text.startswith("ff2 DEVICE SILENT"))
    states = [m.system_status for m in run.gcs if m.get_type() == "HEARTBEAT"
              and m.get_srcSystem() == sysid]
    critical, active = mavutil().mavlink.MAV_STATE_CRITICAL, mavutil().mavlink.MAV_STATE_ACTIVE
    assert critical in states and active in states[states.index(critical):]
    view = run.result.components["live_view"]
    alarms = [a for a in view.book.alarms.values() if a.agent == "ff2"]
    assert [(a.condition, a.state) for a in alarms] == [("device_silent", "returned")]
    logged = [d for d in run.result.diagnostics if d.component == "live_view"
              and d.code == "alarm_device_silent"]
    assert [d.level for d in logged] == ["error", "warning"]  # raised, condition gone
    # the gap is counted, and the track goes on after it
    assert run.count("imu_can", "gaps") >= 1 and run.count("ins", "gaps") >= 1
    assert summary_has(run, "imu_can", "gaps")
    assert_track_continues(run, "ff2", after=FAULT_T + 3.5)


class Duplicates:
    """A retransmission burst: ff1 (CAN) and ff4 (MAVLink) send their last 30 samples'
    frames again, ``repeats`` times, at FAULT_T."""

    def __init__(self, repeats: int):
        self.repeats = repeats
        self.recent: dict[str, list] = {"ff1": [], "ff4": []}
        self.sent_again = {"ff1": 0, "ff4": 0}

    def __call__(self, player, block, link, frames) -> None:
        player.transmit(link, frames)
        if block.agent not in self.recent:
            return
        recent = self.recent[block.agent]
        recent.append((block, frames))
        del recent[:-30]
        if FAULT_T <= block.t < FAULT_T + 0.01:
            for _ in range(self.repeats):
                for old_block, old_frames in recent:
                    player.transmit(link, old_frames)
                    self.sent_again[block.agent] += len(old_block)


def test_burst_of_duplicates_is_dropped_by_the_sensor(tmp_path):
    fault = Duplicates(repeats=3)
    run = run_live(tmp_path, tamper=fault)
    assert fault.sent_again == {"ff1": 90, "ff4": 90}
    # every frame reached the pipeline (receive times differ, so the timeline keeps them);
    # the foot_imu sensor recognises the repeated samples by device time and values
    assert run.count("timeline", "duplicates") == 0
    assert run.count("imu_can", "duplicate_samples") == 90
    assert run.count("imu_mav", "duplicate_samples") == 90
    assert summary_has(run, "imu_mav", "duplicate_samples", 90)
    assert_others_intact(run, set())  # duplicates dropped: every track is the offline one


class Reboot:
    """ff1 (CAN) and ff3 (MAVLink) reboot at FAULT_T: their device clocks restart at 0.5 s."""

    def __init__(self):
        self.step = FAULT_T - 0.5

    def __call__(self, player, block, link, frames) -> None:
        if block.agent in ("ff1", "ff3") and block.t >= FAULT_T:
            link, frames = player.encode(dataclasses.replace(block, time=block.time - self.step))
        player.transmit(link, frames)


def test_device_clock_jump_is_reanchored_by_the_sensor(tmp_path):
    run = run_live(tmp_path, speed=1.0, tamper=Reboot())
    # receive times never jump (one monotonic clock): the sensor's DeviceClock sees it
    assert run.count("timeline", "clock_jumps") == 0
    assert run.count("imu_can", "clock_resyncs") == 1
    assert run.count("imu_mav", "clock_resyncs") == 1
    assert summary_has(run, "imu_mav", "clock_resyncs", 1)
    codes = {(d.component, d.agent) for d in run.result.diagnostics if d.code == "imu_clock_resyncs"}
    assert codes == {("imu_can", "ff1"), ("imu_mav", "ff3")}
    assert_others_intact(run, {"ff1", "ff3"})
    for agent in ("ff1", "ff3"):  # re-anchored: the track goes on after the jump
        assert_track_continues(run, agent, after=FAULT_T + 2.0)


def test_a_clock_jump_after_a_late_first_frame_does_not_step_pipeline_time_back():
    """The device reboots after 3 s (its clock restarts at 0); its first frame had been
    read 0.2 s late, so its pipeline times run 0.2 s behind the receive times. The
    re-anchored clock must continue from there, not step back to the receive time
    (which would drop the following samples as time going backwards)."""
    from firenav_framework.messages import RawFrame
    from firenav_framework.testing import run_component
    from firenav_framework.codecs.mavlink_imu import MavlinkImuCodec
    from firenav_framework.messages import ImuBlock
    from firenav_plugins.sensors.foot_imu import FootImuSensor
    n = 500
    t = np.arange(n) * 0.01
    accel, gyro = np.tile([0.0, 0.0, -9.81], (n, 1)), np.zeros((n, 3))
    device_t = np.where(np.arange(n) < 300, t, t - 3.0)  # reboot at sample 300
    frames = MavlinkImuCodec().encode(ImuBlock.from_arrays(device_t, accel, gyro, frame="FRD"))
    # the first frame is read 0.2 s late (a startup stall), the others 5 ms after sending
    recv = 1000.0 + t + np.where(np.arange(n) == 0, 0.2, 0.005)
    raw = [RawFrame(t=r, t_recv=r, transport="mavlink", channel=f.channel, data=f.data)
           for r, f in zip(recv, frames)]
    rec = run_component(FootImuSensor, {}, [("mav.raw", f) for f in raw])
    times = np.concatenate([b.time for b in rec.on("imu")])
    # the first sample of the new clock only proposes it (the second confirms it): dropped
    assert len(times) == n - 1 and np.all(np.diff(times) > 0)
    np.testing.assert_allclose(np.diff(times), 0.01, atol=1e-9)  # no gap, no step back
