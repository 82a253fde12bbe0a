"""Simulation speed: ten minutes of one firefighter at 100 Hz, and the team demo.

    .venv/bin/python benchmarks/bench_simulator.py

Target (issue 4): well under ten seconds for ten minutes of one firefighter at 100 Hz.
Printed side by side in one run: the whole ``simulate()`` call (realistic foot: heel
and toe rockers, the IMU ringing and flexing on its boot), wall and CPU time; the same
whole call with its foot kinematics evaluated sample by sample instead (one-element
calls, the per-sample Python dispatch the vectorised code avoids; timed on one minute
and scaled to ten); and the array stages of the call.
"""
from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from firenav_framework.simulator import simulate  # noqa: E402
from firenav_framework.simulator.gait import foot_kinematics  # noqa: E402
from firenav_framework.simulator.imu_errors import corrupt  # noqa: E402
from firenav_framework.simulator.imu_grades import get_grade  # noqa: E402
from firenav_framework.simulator.imu_ideal import ideal_imu  # noqa: E402
from firenav_framework.simulator.mount import MountConfig, mount_motion  # noqa: E402


def best_of(fn, n: int = 3) -> tuple[float, object]:
    best, out = float("inf"), None
    for _ in range(n):
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
    return best, out


def cpu_of(fn) -> float:
    """CPU seconds of this process for one call of ``fn``."""
    c0 = time.process_time()
    fn()
    return time.process_time() - c0


def main() -> int:
    simulate("orca_test1", 0, duration_s=5)            # imports, numba caches
    t_one, r = best_of(lambda: simulate("search_area250", 0, duration_s=600.0))
    c_one = cpu_of(lambda: simulate("search_area250", 0, duration_s=600.0))
    rec, tr = r.imu["ff1"], r.truth["ff1"]
    n = len(rec.time)
    table = tr.strides
    t_kin, kin = best_of(lambda: foot_kinematics(table, rec.time))
    pivot = np.array([0.0, 0.0, -0.06])
    t_mount, mount = best_of(lambda: mount_motion(kin, 100.0, MountConfig(), pivot,
                                                  np.random.default_rng(0)))
    t_ideal, (f, w) = best_of(lambda: ideal_imu(kin, latitude_deg=59.4, mount=mount))
    grade = get_grade("xsens_mti3")
    rng = np.random.default_rng(0)
    t_err, _ = best_of(lambda: (corrupt(f, grade.accel, 100.0, rng),
                                corrupt(w, grade.gyro, 100.0, rng, specific_force=f)))
    minute = rec.time[rec.time < rec.time[0] + 60.0]
    t0 = time.perf_counter()
    for ti in minute:
        foot_kinematics(table, ti[None])
    t_loop = (time.perf_counter() - t0) * n / len(minute)
    t_team, team = best_of(lambda: simulate("demo", 0), n=2)
    msgs = sum(len(m) for m in team.messages.values())

    print(f"Simulator speed ({n} IMU samples = {rec.time[-1] - rec.time[0]:.0f} s of one "
          f"firefighter at 100 Hz)")
    print(f"  {'whole simulate() call':<44} {t_one:8.2f} s   wall, {c_one:.2f} s CPU "
          f"(target: well under 10 s)")
    print(f"  {'whole call, kinematics per sample (reference)':<44} "
          f"{t_one - t_kin + t_loop:8.2f} s   wall ({(t_one - t_kin + t_loop) / t_one:.0f}x; "
          f"kinematics scaled from 60 s)")
    print(f"  {'  foot kinematics, vectorised':<44} {t_kin:8.3f} s")
    print(f"  {'  foot kinematics, per sample (reference)':<44} {t_loop:8.2f} s   "
          f"({t_loop / t_kin:.0f}x slower)")
    print(f"  {'  IMU on its boot (mount filters, sway)':<44} {t_mount:8.3f} s")
    print(f"  {'  ideal IMU (rotations, Earth rate)':<44} {t_ideal:8.3f} s")
    print(f"  {'  sensor errors (accel + gyro)':<44} {t_err:8.3f} s")
    print(f"Team demo: {len(team.truth)} firefighters, {team.t_end:.0f} s, IMU+UWB+RFID+RSSI, "
          f"{msgs} messages: {t_team:.2f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
