"""A throw-away "installed" third-party package: a module plus its dist-info on a folder
that is put on the path (importlib.metadata finds its entry points as pip's would)."""
from __future__ import annotations

import os
import subprocess
import sys
import textwrap
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]


def make_dist(site: Path, dist: str, modules: dict[str, str],
              entry_points: dict[str, dict[str, str]], version: str = "1.0") -> None:
    """Write ``modules`` (name -> source) and ``<dist>-<version>.dist-info`` into ``site``."""
    site.mkdir(parents=True, exist_ok=True)
    for name, source in modules.items():
        (site / f"{name}.py").write_text(textwrap.dedent(source))
    info = site / f"{dist.replace('-', '_')}-{version}.dist-info"
    info.mkdir(exist_ok=True)
    (info / "METADATA").write_text(f"Metadata-Version: 2.1\nName: {dist}\nVersion: {version}\n")
    (info / "entry_points.txt").write_text("".join(
        f"[{group}]\n" + "".join(f"{k} = {v}\n" for k, v in eps.items())
        for group, eps in entry_points.items()))


def firenav(site: Path, *args: str, env: dict[str, str] | None = None,
            timeout: float = 120) -> subprocess.CompletedProcess:
    """``firenav ARGS`` in a fresh interpreter that sees the packages of ``site``."""
    full = {**os.environ, "PYTHONPATH": os.pathsep.join([str(site), str(REPO)]), **(env or {})}
    return subprocess.run([sys.executable, "-m", "firenav_framework", *args], cwd=REPO,
                          env=full, capture_output=True, text=True, timeout=timeout)
