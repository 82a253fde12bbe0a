"""The ``recording`` source: replays a recorded file through any pipeline.

The reader is chosen by the file's suffix (or the ``format`` parameter) from the
table in :mod:`firenav_framework.sources.readers`, which says what each format
yields. ``firenav run PIPELINE --input FILE`` sets ``path``.

What a reader reports with ``options.warn`` (an empty log, a damaged region skipped, a
device's file that cannot be read) goes to the log (stderr) at once and becomes a
``warning`` diagnostic of this source, once per message.
"""
from __future__ import annotations

import logging
from collections.abc import Iterator
from pathlib import Path

from pydantic import field_validator

from ..contract import Params, Source, param
from ..formats.csv_layout import CsvColumns
from ..messages import Message
from .readers import PORTS, ReaderError, ReadOptions, find_reader, reader_table

log = logging.getLogger("firenav.recording")


class RecordingSource(Source):
    """Replay a recorded file (real foot-IMU datasets, IMU CSV, link logs) as messages."""

    name = "recording"
    input_param = "path"
    #: The ports every recording offers; reader modules may add more (output_ports).
    outputs = dict(PORTS)

    class Params(Params):
        path: str | None = param(None)
        """recorded file, relative to the pipeline file; `firenav run --input FILE` sets it"""
        format: str = param("auto")
        """'auto' (by suffix; .mat by its variables, .csv/.txt by their header) or a format name /
        suffix, e.g. imu_csv, csv_columns, xio_gait_tracking, zupt_fgo, gaitmap, openshoe,
        pyshoe_vicon, indoor_walk, csv, mat"""
        agent: str = param("ff1", min_length=1)
        """firefighter the file's data belong to, unless the file says"""
        device: str | None = param(None)
        """device id of the IMU data unless the file says (default '<agent>/imu')"""
        block_s: float = param(0.1, unit="s", gt=0, le=10)
        """length of the ImuBlock pieces IMU data are cut into"""
        time_offset: float = param(0.0, unit="s")
        """added to every time in the file (to line it up with other sources)"""
        columns: CsvColumns | None = param(None)
        """column and unit mapping of a CSV / text IMU recording (docs/formats/csv-columns.md);
        over a public format or a sidecar file, its keys replace theirs"""

        @field_validator("format")
        @classmethod
        def _known_format(cls, fmt: str) -> str:
            if fmt != "auto":
                find_reader("", fmt)  # raises ReaderError (a ValueError) listing the formats
            return fmt

    @classmethod
    def output_ports(cls, params: Params) -> dict[str, type[Message]]:
        if params.path and params.format == "auto":
            find_reader(params.path)  # an unknown suffix is reported at validation time
        return {**reader_table().ports, **super().output_ports(params)}

    def __init__(self, params: Params, ctx):
        super().__init__(params, ctx)
        if not params.path:
            raise ReaderError("no file to replay: set `path` or run with --input FILE")
        path = ctx.resolve(params.path)
        if not path.is_file():
            raise ReaderError(f"recording '{params.path}' not found (looked for {path})")
        self.path: Path = path
        self._pending: list[tuple[str, str]] | None = []  # warnings before start()
        self._t = 0.0
        options = ReadOptions(agent=params.agent, device=params.device or "",
                              block_s=params.block_s, count=ctx.count, warn=self._warn,
                              columns=params.columns)
        self._reader = find_reader(path, params.format)(path, options)

    def _warn(self, code: str, text: str) -> None:
        log.warning("%s: %s", self.ctx.id, text)
        if self._pending is not None:
            self._pending.append((code, text))
        else:
            self.ctx.warn_once(self._t, code, text, key=text)

    def start(self) -> None:
        pending, self._pending = self._pending or [], None
        for code, text in pending:
            self.ctx.warn_once(self._t, code, text, key=text)

    def duration(self) -> tuple[float, float] | None:
        span = getattr(self._reader, "duration", lambda: None)()
        if span is None:
            return None
        return span[0] + self.params.time_offset, span[1] + self.params.time_offset

    def messages(self) -> Iterator[tuple[str, Message]]:
        dt = self.params.time_offset
        for port, msg in self._reader:
            msg = msg.shifted(dt) if dt else msg
            self._t = msg.t
            yield port, msg
