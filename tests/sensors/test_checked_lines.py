"""The shared ``KIND,...*HH`` line framing of the RFID reader and the UWB tag."""
import numpy as np
import pytest

from firenav_framework.codecs import FrameError
from firenav_framework.codecs.checked_lines import checksum, decode_fields, encode_fields


def test_checksum_is_the_xor_of_every_byte():
    body = b"RANGE,7,A0,12345,-80.5,-83.0,17"
    assert checksum(body) == int(np.bitwise_xor.reduce(np.frombuffer(body, np.uint8)))
    assert checksum(b"") == 0


def test_lines_round_trip_with_and_without_checksum():
    fields = ["TAG", "boot-ff1", "door.12", "-61.0"]
    line = encode_fields(fields)
    assert line.startswith(b"TAG,boot-ff1,door.12,-61.0*")
    assert decode_fields(line + b"\r\n", ("TAG",)) == fields
    assert decode_fields(encode_fields(fields, with_checksum=False), ("TAG",)) == fields


def test_other_kinds_are_not_ours_and_broken_lines_say_why():
    assert decode_fields(b"$GPGGA,1,2*00", ("TAG", "RANGE")) is None
    line = bytearray(encode_fields(["RANGE", "7", "A0", "1000", "", ""]))
    line[8] ^= 0x01                        # one flipped bit in the body
    with pytest.raises(FrameError) as e:
        decode_fields(bytes(line), ("RANGE",))
    assert e.value.code == "checksum_errors"
    with pytest.raises(FrameError) as e:
        decode_fields(b"RANGE,7,A0,1000*ZZ", ("RANGE",))
    assert e.value.code == "checksum_errors"
    with pytest.raises(FrameError) as e:
        decode_fields(b"RANGE,\xff\xfe", ("RANGE",))
    assert e.value.code == "bad_frames" and "ASCII" in str(e.value)
