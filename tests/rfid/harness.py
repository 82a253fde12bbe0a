"""Run a pipeline and keep the messages of some of its streams (for tests and benchmarks)."""
from __future__ import annotations

from collections import defaultdict

from firenav_framework.runner import Runner


def run_tapped(spec, streams: tuple[str, ...]):
    """Run pipeline ``spec``; (its RunResult, {stream: [messages in bus order]}) for
    the ``streams`` asked for (``component.port`` names)."""
    runner = Runner(spec)
    seen: dict[str, list] = defaultdict(list)
    build = runner.build

    def build_and_tap():
        build()
        runner.bus.taps.append(lambda s, m: seen[s].append(m) if s in streams else None)
    runner.build = build_and_tap
    return runner.run(), seen
