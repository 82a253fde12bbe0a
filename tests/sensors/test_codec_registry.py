"""The codec registry: every built-in codec is well formed and round-trips its records;
unknown and broken codecs fail with a clear reason."""
from __future__ import annotations

import importlib.metadata as md

import numpy as np
import pytest

import firenav_framework.codecs as codecs
from firenav_framework.codecs import BUILTIN_CODECS, Codec, UnknownCodec, get_codec, to_raw_frames
from firenav_framework.codecs.baro_lines import BaroReading
from firenav_framework.codecs.breadcrumb_lines import RadioEvent
from firenav_framework.codecs.imu_sample import ImuSample
from firenav_framework.codecs.rfid_lines import RfidEvent
from firenav_framework.codecs.twr_report import TwrReport
from firenav_framework.messages import ImuBlock

_rng = np.random.default_rng(7)
_T = 3.0 + np.arange(40) * 0.005
IMU = ImuBlock.from_arrays(_T, _rng.normal(0, 5, (40, 3)), _rng.normal(0, 1, (40, 3)),
                           frame="device")
RECORDS = {
    TwrReport: [TwrReport(1.0, "3", "7", 12.345, -81.5, -84.0, 17),
                TwrReport(1.5, "3", "7", None, None, None, 18)],
    RfidEvent: [RfidEvent(2.0, "DEPLOY", "ff1/rfid", "E2AA"),
                RfidEvent(2.5, "TAG", "ff1/rfid", "E2AA", -48.5, 3)],
    BaroReading: [BaroReading(3.0, "ff1/baro", 101325.25, 294.65),
                  BaroReading(3.5, "base/baro", 98765.5)],
    RadioEvent: [RadioEvent(4.0, "RSSI", "ff3/radio", "base", -67.5),
                 RadioEvent(4.5, "DROP", "ff3/dispenser", "bc1")],
}
#: Largest round-trip error of an IMU codec's accel [m/s^2] and gyro [rad/s] (its quantisation).
IMU_TOLERANCE = {"can_imu": (0.0025, 0.00025), "mavlink_imu": (1e-5, 1e-6),
                 "imu_lines": (0.0, 0.0)}


@pytest.mark.parametrize("name", sorted(BUILTIN_CODECS))
def test_a_builtin_codec_is_well_formed_and_round_trips_its_records(name):
    cls = get_codec(name)
    assert issubclass(cls, Codec) and cls.name == name and cls.summary()
    assert cls.transport in ("can", "mavlink", "lines")
    for field, info in cls.Options.model_fields.items():
        assert info.description, f"{name}.Options.{field} needs a description"
    codec = cls()
    transport = "serial" if cls.transport == "lines" else cls.transport
    address = (codec.addresses() or [""])[-1]
    if cls.record is ImuSample:
        encoded = codec.encode(IMU, address=address)
    else:
        encoded = codec.encode(RECORDS[cls.record], address=address)
    channels = codec.channels(address)
    if channels is not None:
        assert {f.channel for f in encoded} <= set(channels)
    raw = to_raw_frames(encoded, transport=transport, device="dev0")
    decoded = [r for f in raw for r in codec.decode(f) or []]
    codec.finish()
    if cls.record is ImuSample:
        acc_tol, gyro_tol = IMU_TOLERANCE[name]
        assert len(decoded) == len(IMU)
        np.testing.assert_allclose([s.t for s in decoded], IMU.time, atol=1e-6)
        np.testing.assert_allclose([s.accel for s in decoded], IMU.accel, rtol=1e-6,
                                   atol=acc_tol + 1e-9)
        np.testing.assert_allclose([s.gyro for s in decoded], IMU.gyro, rtol=1e-6,
                                   atol=gyro_tol + 1e-9)
        assert len({s.device for s in decoded}) == 1
    else:
        assert decoded == RECORDS[cls.record]


def test_an_unknown_name_suggests_the_close_ones():
    with pytest.raises(UnknownCodec, match="no codec named 'mavlink_imus'; did you mean "
                                           "'mavlink_imu'"):
        get_codec("mavlink_imus")


@pytest.fixture
def entry_point(monkeypatch):
    """Add one entry point to the firenav.codecs group."""
    real = md.entry_points

    def add(name: str, value: str) -> None:
        ep = md.EntryPoint(name=name, value=value, group=codecs.CODEC_GROUP)
        monkeypatch.setattr(codecs.md, "entry_points", lambda **kw: md.EntryPoints(
            [*real(**kw), ep]) if kw.get("group") == codecs.CODEC_GROUP else real(**kw))
        codecs._entry_points.cache_clear()
        codecs.get_codec.cache_clear()

    yield add
    codecs._entry_points.cache_clear()
    codecs.get_codec.cache_clear()


def test_a_codec_package_that_fails_to_import_is_named_with_its_error(entry_point):
    entry_point("broken_imu", "no_such_vendor_package.codec:Broken")
    assert "broken_imu" in codecs.codec_names()
    with pytest.raises(UnknownCodec, match="'broken_imu' failed to load: ModuleNotFoundError"):
        get_codec("broken_imu")
    assert get_codec("can_imu").name == "can_imu"       # the others still load


def test_an_entry_point_must_name_a_codec_of_its_own_name(entry_point):
    entry_point("acme_alias", "tests.sensors.acme_codec:AcmeCanImuCodec")
    with pytest.raises(UnknownCodec, match="does not name a Codec subclass called 'acme_alias'"):
        get_codec("acme_alias")
