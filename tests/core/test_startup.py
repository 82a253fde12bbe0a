"""Start-up of the command line: only the named command is imported, numba's compiling
is announced while it happens, and the plot can be drawn in a renderer process."""
from __future__ import annotations

import io
import subprocess
import sys

from numba import njit

from firenav_framework.cli import _named_command, build_parser
from firenav_framework.cli.run import compile_notice


def test_only_the_named_command_is_imported():
    code = ("import sys; from firenav_framework.cli import build_parser; "
            "build_parser(['run', 'x.yaml']); "
            "print(sorted(m for m in sys.modules if m.startswith('firenav_framework.cli.')))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout
    assert out.strip() == "['firenav_framework.cli.run']"
    assert _named_command(["-v", "plugins", "list"]) == "plugins"
    assert _named_command(["--help", "run"]) is None and _named_command([]) is None
    assert _named_command(["nonsense"]) is None       # argparse then lists every command
    full = build_parser(["--help"])
    assert {"run", "plugins", "replay", "simulate"} <= set(
        full._subparsers._group_actions[0].choices)


def test_numba_compiling_is_announced_with_progress():
    @njit(cache=False)
    def fresh(x):          # never compiled before: numba compiles it on this call
        return x + 1

    stream = io.StringIO()
    with compile_notice(stream) as notice:
        assert fresh(1) == 2
        assert fresh(2) == 3                          # compiled once
    lines = stream.getvalue().splitlines()
    assert lines[0].startswith("[firenav] compiling (first run only)")
    assert "fresh" in lines[1] and "(1 kernels" in lines[1]
    assert notice.kernels == 1
    with compile_notice(None) as silent:
        assert silent is None
