"""Extension template for a firenav SOURCE: where messages come from.

How to use it:

1. Copy this file into your package and rename the class ``<Name>Source``; work through
   the ``TODO`` markers.
2. Register it: ``"source.my_checkpoints" = "acme_firenav.source:MySource"``.
3. Test it with ``firenav_framework.testing.check_plugin(MySource, {"path": ...},
   faulty_params=[{"path": <a damaged file>}])``: a source's bad input is in its data.

As it is, the class is a working example: surveyed checkpoints from a text file of
``t,agent,x,y,z`` lines become ``GroundTruth`` messages. It passes ``check_plugin``.

The contract (``firenav_framework/contract/source.py``):

* ``messages()`` yields ``(port, message)`` pairs, each port in (mostly) increasing
  time; the timeline merges the sources and puts late arrivals back in order.
* A live source (``live = True``) blocks waiting for data in its own thread, and
  ``stop()`` must make ``messages()`` return soon; it records every raw frame before
  publishing it.
* ``input_param`` names the parameter ``firenav run --input PATH`` sets.
* A source that brings its own building sets ``provides_building`` and returns it from
  ``building()``.
* Bad records are counted (``ctx.count``), reported and skipped; never raised.
"""
from __future__ import annotations

import math
from collections.abc import Iterator
from pathlib import Path

import numpy as np

from firenav_framework import GroundTruth, Message, Params, Source, param


class MySource(Source):
    """Surveyed checkpoints: lines of t,agent,x,y,z as ground-truth positions."""

    # TODO: the name pipelines use; unique among sources.
    name = "my_checkpoints"
    # TODO: the ports it yields and their message types.
    outputs = {"truth": GroundTruth}
    # TODO: the parameter `firenav run --input PATH` sets (None: none).
    input_param = "path"

    class Params(Params):
        # TODO: your parameters.
        path: str = param()
        """checkpoint file (t,agent,x,y,z per line; # comments), relative to the pipeline file"""

    def __init__(self, params: Params, ctx):
        super().__init__(params, ctx)
        path = Path(params.path).expanduser()
        self.path = path if path.is_absolute() else ctx.base_dir / path
        if not self.path.is_file():  # a wrong path fails when the pipeline is built
            raise ValueError(f"checkpoint file {self.path} not found")

    def messages(self) -> Iterator[tuple[str, Message]]:
        # TODO: produce your messages.
        with self.path.open(encoding="utf-8") as lines:
            for number, line in enumerate(lines, 1):
                line = line.strip()
                if not line or line.startswith("#"):
                    continue
                truth = self._parse(line)
                if truth is None:
                    self.ctx.count("bad_lines")
                    self.ctx.report(0.0, "bad_line", f"{self.path.name}:{number}: not "
                                    f"t,agent,x,y,z with finite numbers", key=self.path.name)
                    continue
                yield "truth", truth

    @staticmethod
    def _parse(line: str) -> GroundTruth | None:
        fields = line.split(",")
        if len(fields) != 5 or not fields[1].strip():
            return None
        try:
            t, x, y, z = (float(fields[k]) for k in (0, 2, 3, 4))
        except ValueError:
            return None
        if not all(math.isfinite(v) for v in (t, x, y, z)):
            return None
        return GroundTruth(t=t, agent=fields[1].strip(), device="survey",
                           position=np.array([x, y, z]))
