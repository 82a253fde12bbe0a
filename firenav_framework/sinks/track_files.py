"""Track files: CSV written row by row as poses arrive, GeoJSON at the end."""
from __future__ import annotations

from typing import IO

from ..contract import OutputName, Params, param
from ..messages import PoseEstimate
from ..tracks import CSV_HEADER, TrackStore, pose_csv_row, write_geojson
from ..contract import FileSink


class CsvTracks(FileSink):
    """Write pose estimates as CSV (t, agent, x, y, z, heading, covariances, floor)."""

    name = "csv_tracks"
    inputs = (PoseEstimate,)

    class Params(Params):
        file: OutputName = param("{stream}.csv")
        """file name under the output folder; {stream} is replaced by the input stream (dots become
        _)"""
        flush_every: int = param(50, ge=1)
        """flush to disk every this many rows, so a crash loses at most that many"""

    def start(self) -> None:
        self._files: dict[str, IO[str]] = {}
        self._rows = 0

    def handle(self, stream: str, msg: PoseEstimate) -> None:
        fh = self._files.get(stream)
        if fh is None:
            name = self.params.file.format(stream=self.stream_slug(stream))
            existing = next((f for f in self._files.values() if f.name == str(self.out_path(name))), None)
            fh = existing or open(self.out_path(name), "w", encoding="utf-8", newline="")
            if existing is None:
                fh.write(CSV_HEADER + "\n")
            self._files[stream] = fh
        fh.write(pose_csv_row(msg) + "\n")
        self._rows += 1
        if self._rows % self.params.flush_every == 0:
            fh.flush()

    def finish(self) -> None:
        for fh in {id(f): f for f in self._files.values()}.values():
            fh.close()
        self._files.clear()


class GeoJsonTracks(FileSink):
    """Write each agent's track as a GeoJSON LineString: RFC 7946 WGS84 when the building
    is georeferenced, else plan metres, said in the file's ``coordinate_frame``."""

    name = "geojson_tracks"
    inputs = (PoseEstimate,)

    class Params(Params):
        file: OutputName = param("tracks.geojson")
        """file name under the output folder"""

    def start(self) -> None:
        self._store = TrackStore()

    def handle(self, stream: str, msg: PoseEstimate) -> None:
        self._store(stream, msg)

    def finish(self) -> None:
        georef = None
        try:
            georef = getattr(self.ctx.building, "georef", None)
        except RuntimeError:  # no building in this pipeline: local coordinates
            pass
        write_geojson(self.out_path(self.params.file), self._store.tracks(), georef)
PLUGINS = [CsvTracks, GeoJsonTracks]
