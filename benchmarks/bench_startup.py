"""Start-up and short runs: ``firenav run pipelines/foot-ins.yaml`` end to end, whole process.

Whole-process wall and CPU time (this process's children, by ``os.wait4``), median of
``--runs`` runs after one warm-up, each command in turn (A B A B ...), for

* ``firenav run pipelines/foot-ins.yaml`` on the real 43 s indoor walk (``walk_31``) and
  on a 2-minute recording (walks 37 and 34 one after the other, written as an IMU CSV
  into a temporary folder), the warm case: numba's cache already filled;
* ``firenav plugins list``;
* a first run with an empty numba cache (``NUMBA_CACHE_DIR`` a new folder): the time to
  its first line on the terminal (the run itself is then stopped: it would compile for
  a minute or two);
* optionally any peer command given with ``--peer 'COMMAND'`` (e.g. another INS script
  on the same file), beside ours in the same alternation.

    python benchmarks/bench_startup.py [--runs 5] [--peer 'python their_script.py walk_31.mat']
"""
from __future__ import annotations

import argparse
import os
import shlex
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
DATA = REPO.parent / "shared" / "data" / "indoor-walks"
FIRENAV = str(Path(sys.executable).with_name("firenav"))


def two_minute_csv(folder: Path) -> Path:
    """Walks 37 and 34 (98 s + 26 s) one after the other as one IMU CSV recording."""
    from firenav_framework.formats.imu_csv import write_imu_csv
    from firenav_framework.messages import ImuBlock
    from firenav_framework.sources.readers.foot_imu_datasets import load_indoor_walk

    walks = [load_indoor_walk(DATA / f"walk_{n}.mat") for n in (37, 34)]
    t = np.concatenate([w.ts - w.ts[0] + (0.0 if i == 0 else walks[0].ts[-1] - walks[0].ts[0]
                                          + 0.005) for i, w in enumerate(walks)])
    imu = np.vstack([w.imu for w in walks])
    path = folder / "walk_37_34.csv"
    blocks = [ImuBlock.from_arrays(t[i:i + 200], imu[i:i + 200, :3], imu[i:i + 200, 3:],
                                   agent="ff1", device="ff1/imu", frame="device")
              for i in range(0, len(t), 200)]
    write_imu_csv(path, blocks)
    return path


def timed(cmd: list[str], env: dict | None = None) -> tuple[float, float]:
    """(wall s, CPU s of the process and its children) of one run of ``cmd``."""
    t0 = time.perf_counter()
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=env)
    _, _, ru = os.wait4(proc.pid, 0)
    return time.perf_counter() - t0, ru.ru_utime + ru.ru_stime


def first_line(cmd: list[str], env: dict) -> float:
    """Seconds until ``cmd`` prints its first line on stderr (then it is stopped)."""
    t0 = time.perf_counter()
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, env=env)
    proc.stderr.readline()
    dt = time.perf_counter() - t0
    proc.kill()
    proc.wait()
    return dt


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--peer", action="append", default=[], metavar="COMMAND",
                    help="a command to time beside ours (repeatable)")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        long = two_minute_csv(tmp)
        run = [FIRENAV, "run", str(REPO / "pipelines" / "foot-ins.yaml"), "--quiet",
               "--output", str(tmp / "out"), "--input"]
        commands = {"firenav run foot-ins, 43 s walk": run + [str(DATA / "walk_31.mat")],
                    "firenav run foot-ins, 2 min recording": run + [str(long)],
                    "firenav plugins list": [FIRENAV, "plugins", "list"]}
        for i, peer in enumerate(args.peer):
            commands[f"peer {i + 1}: {peer}"] = shlex.split(peer)
        for cmd in commands.values():      # warm-up: caches, page cache
            timed(cmd)
        figures: dict[str, list[tuple[float, float]]] = {name: [] for name in commands}
        for _ in range(args.runs):
            for name, cmd in commands.items():
                figures[name].append(timed(cmd))
        env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp / "empty-numba-cache"))
        cold = first_line([FIRENAV, "run", str(REPO / "pipelines" / "foot-ins.yaml"),
                           "--output", str(tmp / "cold"), "--input", str(DATA / "walk_31.mat")],
                          env)
    print(f"median of {args.runs} runs, whole process (wall / CPU incl. children); "
          f"{os.cpu_count()} cores, load average {os.getloadavg()[0]:.1f}")
    for name, rows in figures.items():
        wall = statistics.median(r[0] for r in rows)
        cpu = statistics.median(r[1] for r in rows)
        print(f"  {name:<60} {wall:6.2f} s wall  {cpu:6.2f} s CPU  "
              f"(min {min(r[0] for r in rows):.2f} s wall)")
    print(f"  {'first run, empty numba cache: first line printed after':<60} {cold:6.2f} s "
          f"(goal: within 2 s)")


if __name__ == "__main__":
    main()
