"""A vendor adds a wire protocol without a sensor: a codec registered under the
``firenav.codecs`` entry-point group is used by name by the foot_imu sensor and by the
player, exactly like a built-in one."""
from __future__ import annotations

import importlib.metadata as md
import uuid

import can
import numpy as np
import pytest
from pydantic import ValidationError

import firenav_framework.codecs as codecs
from firenav_framework.messages import ImuBlock
from firenav_framework.testing import run_component
from firenav_framework.transports.can_link import can_frame
from firenav_framework.transports.player import DevicePlayer, Roster
from firenav_plugins.sensors.foot_imu import FootImuSensor

from .acme_codec import ACCEL_LSB, GYRO_LSB, AcmeCanImuCodec

ACME = md.EntryPoint(name="acme_can_imu", value="tests.sensors.acme_codec:AcmeCanImuCodec",
                     group=codecs.CODEC_GROUP)


def _clear_caches() -> None:
    codecs._entry_points.cache_clear()
    codecs.get_codec.cache_clear()


@pytest.fixture
def acme_installed(monkeypatch):
    """The ACME package's entry point, as if it were pip-installed."""
    real = md.entry_points

    def entry_points(**kw):
        found = real(**kw)
        return md.EntryPoints([*found, ACME]) if kw.get("group") == codecs.CODEC_GROUP else found

    monkeypatch.setattr(codecs.md, "entry_points", entry_points)
    _clear_caches()
    yield
    _clear_caches()


def walk(agent: str, device: str, n: int = 300, rate: float = 100.0) -> list[ImuBlock]:
    """A z-down device swinging gently, in 0.1 s blocks (device clock from 2.5 s)."""
    t = 2.5 + np.arange(n) / rate
    phase = 2 * np.pi * 1.8 * (t - t[0])
    accel = np.column_stack((3 * np.sin(phase), 0.5 * np.cos(phase), -9.81 + 2 * np.sin(2 * phase)))
    gyro = np.column_stack((0.2 * np.cos(phase), 1.5 * np.sin(phase), 0.1 * np.sin(3 * phase)))
    return [ImuBlock.from_arrays(t[i:i + 10], accel[i:i + 10], gyro[i:i + 10], agent=agent,
                                 device=device, frame="device") for i in range(0, n, 10)]


def test_without_the_package_the_name_is_unknown():
    _clear_caches()
    assert "acme_can_imu" not in codecs.codec_names()
    with pytest.raises(ValidationError, match="no codec named 'acme_can_imu'"):
        FootImuSensor.Params(frames={"codecs": {"can": "acme_can_imu"}})


def test_the_registered_codec_is_found_by_name(acme_installed):
    assert "acme_can_imu" in codecs.codec_names()
    assert codecs.get_codec("acme_can_imu") is AcmeCanImuCodec
    assert "can_imu" in codecs.codec_names()                 # the built-ins are still there
    with pytest.raises(ValidationError, match="nodes: Input should be less than or equal to 16"):
        FootImuSensor.Params(frames={"codecs": {"can": "acme_can_imu"},
                                     "codec_options": {"acme_can_imu": {"nodes": 40}}})


def test_the_player_sends_with_it_and_foot_imu_decodes_with_it(acme_installed):
    channel = f"acme-{uuid.uuid4().hex}"
    tx = can.Bus(interface="virtual", channel=channel)
    rx = can.Bus(interface="virtual", channel=channel)
    try:
        player = DevicePlayer(can_bus=tx, speed=0, codecs={"can": "acme_can_imu"})
        roster = Roster(feet={"ff1/imu": "right"}, mavlink_agents=set())
        sent = walk("ff1", "ff1/imu")
        for block in sent:
            assert player.assignment(block, roster) is not None
            player.send(block)
        assignment = player.assignments["ff1/imu"]
        # the vendor codec's addresses and ids, not the reference layout's
        assert (assignment.link, assignment.address) == ("can", "node1")
        assert str(assignment) == "CAN node1 (ids 0x310-0x311)"
        received = []
        while (msg := rx.recv(0.2)) is not None:
            received.append(msg)
    finally:
        tx.shutdown()
        rx.shutdown()
    assert {m.arbitration_id for m in received} == {0x310, 0x311}
    assert len(received) == 2 * 300 == player.sent["can"]
    frames = [can_frame(int(1_700_000_000_000_000 + 5_000 * i), m)
              for i, m in enumerate(received)]
    params = {"axes": ["x", "-y", "-z"],
              "frames": {"codecs": {"can": "acme_can_imu"},
                         "agent_map": {"*/node1": "ff1/right_foot"}}}
    rec = run_component(FootImuSensor, params, [("raw", f) for f in frames])
    out = rec.on("imu")
    assert {(b.agent, b.device) for b in out} == {("ff1", "ff1/right_foot")}
    time = np.concatenate([b.time for b in out])
    accel = np.concatenate([b.accel for b in out])
    gyro = np.concatenate([b.gyro for b in out])
    t_in = np.concatenate([b.time for b in sent])
    assert len(time) == 300
    # device clock in whole milliseconds, one offset onto the receive clock
    np.testing.assert_allclose(np.diff(time), np.diff(t_in), atol=1e-6)
    flip = np.array([1.0, -1.0, -1.0])                       # FRD device -> FLU
    np.testing.assert_allclose(accel, np.concatenate([b.accel for b in sent]) * flip,
                               atol=ACCEL_LSB / 2 + 1e-9)
    np.testing.assert_allclose(gyro, np.concatenate([b.gyro for b in sent]) * flip,
                               atol=GYRO_LSB / 2 + 1e-9)


def test_the_team_layout_follows_the_vendor_codecs_addresses(acme_installed):
    player = DevicePlayer(codecs={"can": "acme_can_imu"})     # two nodes: one firefighter
    roster = Roster(mavlink_agents=set())
    left, right = walk("ff1", "ff1/left", 10)[0], walk("ff1", "ff1/right", 10)[0]
    assert [player.assignment(b, roster).address for b in (left, right)] == ["node0", "node1"]
    with pytest.raises(ValueError, match="2 device addresses .* send it over MAVLink"):
        player.assignment(walk("ff2", "ff2/left", 10)[0], roster)
