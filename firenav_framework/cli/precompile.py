"""``firenav precompile``: compile and cache the numba kernels now, not in the first run.

The array kernels (INS filter, detectors, particle updates, frame decoding ...) are
compiled by numba the first time they run and cached beside their modules (or under
``$NUMBA_CACHE_DIR``); a first run therefore spends a minute or two compiling. This
command runs every installed sensor, estimator and constraint on the bundled sample
input (a short simulated team run) and every IMU codec through a round trip of frames,
which compiles and caches what they use. Run it once after installing (the README's install line
does), or keep ``$NUMBA_CACHE_DIR`` between CI runs.
"""
from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

from .run import compile_notice

KINDS = ("sensor", "estimator", "constraint")


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("precompile", help="compile and cache the array kernels now "
                       "(otherwise the first run does, for a minute or two)")
    p.set_defaults(func=precompile)


def precompile(args: argparse.Namespace) -> int:
    from ..codecs import codec_names, get_codec
    from ..registry import default_registry
    from ..testing import plugin_case, run_checks

    t0 = time.monotonic()
    failed: list[str] = []
    reg = default_registry()
    with compile_notice(sys.stderr) as notice, tempfile.TemporaryDirectory() as tmp:
        for kind in KINDS:
            for name in reg.names(kind):
                info = reg.get(kind, name)
                try:
                    case = plugin_case(info.cls, workdir=Path(tmp))
                    outcome = run_checks(case, ["ports"])["ports"]
                except Exception as exc:  # noqa: BLE001 - report it, go on with the others
                    outcome = exc
                if isinstance(outcome, BaseException):
                    failed.append(f"{kind} {name}: {type(outcome).__name__}: {outcome}")
        for name in codec_names():
            try:
                _imu_codec_round(get_codec(name))
            except Exception as exc:  # noqa: BLE001
                failed.append(f"codec {name}: {type(exc).__name__}: {exc}")
    for line in failed:
        print(f"warning: not compiled through {line}", file=sys.stderr)
    print(f"{notice.kernels if notice else 0} kernels compiled and cached in "
          f"{time.monotonic() - t0:.0f} s")
    return 0


def _imu_codec_round(cls: type) -> None:
    """Encode a second of samples with an IMU codec and decode the frames in a batch."""
    import numpy as np

    from ..codecs import to_raw_frames
    from ..codecs.imu_sample import ImuSample
    from ..messages import ImuBlock

    if not issubclass(cls.record, ImuSample):
        return
    codec = cls()
    t = np.arange(200) / 200.0
    block = ImuBlock.from_arrays(t, np.tile([0.0, 0.0, -9.81], (200, 1)),
                                 np.zeros((200, 3)), frame="device")
    try:
        encoded = codec.encode(block)
    except NotImplementedError:
        return
    codec.decode_batch(to_raw_frames(encoded, transport=cls.transport, device="dev"))
