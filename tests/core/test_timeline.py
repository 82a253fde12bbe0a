"""Timeline rules: order, reorder window, duplicates, late messages, clock jumps, gaps, ticks."""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from firenav_framework.messages import Diagnostic, GroundTruth, ImuBlock, Tick
from firenav_framework.timeline import Timeline, TimelineConfig


def gt(t: float, device: str = "d1", x: float = 0.0) -> GroundTruth:
    return GroundTruth(t=t, agent="a", device=device, position=np.array([x, 0.0, 0.0]))


def drain(tl: Timeline, flush: bool = True) -> list:
    return tl.release(flush=flush)


def data(out: list) -> list[float]:
    return [m.t for s, m in out if not isinstance(m, (Diagnostic, Tick))]


@settings(max_examples=60, deadline=None)
@given(st.lists(st.floats(0, 100, allow_nan=False), min_size=1, max_size=60),
       st.integers(1, 4))
def test_merged_output_is_sorted_and_complete(times, n_streams):
    """Whatever the arrival order across streams, one sorted sequence comes out."""
    tl = Timeline(TimelineConfig(reorder_window=1000, duplicates="keep"))
    for i, t in enumerate(times):
        tl.push(f"s{i % n_streams}", gt(t, device=f"d{i % n_streams}", x=i))
    out = data(drain(tl))
    assert out == sorted(times)


def test_late_arrivals_within_the_window_are_put_in_order():
    tl = Timeline(TimelineConfig(reorder_window=0.5))
    released = []
    for t in [0.0, 0.1, 0.3, 0.2, 0.6, 0.4, 1.0, 2.0]:
        tl.push("s", gt(t, x=t))
        released += tl.release()
    released += tl.release(flush=True)
    assert data(released) == [0.0, 0.1, 0.2, 0.3, 0.4, 0.6, 1.0, 2.0]


def test_messages_older_than_released_ones_are_dropped_and_counted():
    tl = Timeline(TimelineConfig(reorder_window=0.2))
    for t in [0.0, 1.0, 2.0]:
        tl.push("s", gt(t, x=t))
    first = tl.release()
    assert data(first) == [0.0, 1.0]
    tl.push("s", gt(0.5, x=9))  # older than 1.0, which is already out
    assert data(drain(tl)) == [2.0]
    assert tl.stats.counts["timeline"]["late_dropped"] == 1


def test_late_deliver_rule_passes_them_on_out_of_order():
    tl = Timeline(TimelineConfig(reorder_window=0.2, late="deliver"))
    for t in [0.0, 1.0, 2.0]:
        tl.push("s", gt(t, x=t))
    tl.release()
    tl.push("s", gt(0.5, x=9))
    assert data(drain(tl)) == [0.5, 2.0]
    assert tl.stats.counts["timeline"]["late_delivered"] == 1


def test_exact_duplicates_are_dropped_but_equal_times_with_other_content_are_kept():
    tl = Timeline()
    tl.push("s", gt(1.0, x=1))
    tl.push("s", gt(1.0, x=1))          # duplicate
    tl.push("s", gt(1.0, x=2))          # same time, other content
    tl.push("s", gt(1.0, device="d2", x=1))  # another device: a different channel
    assert len(data(drain(tl))) == 3
    assert tl.stats.counts["timeline"]["duplicates"] == 1


def test_duplicate_imu_blocks_are_recognised_by_content():
    def block(t0):
        time = t0 + np.arange(5) * 0.01
        return ImuBlock.from_arrays(time, np.ones((5, 3)), np.zeros((5, 3)), device="imu")
    tl = Timeline()
    for t0 in [0.0, 0.05, 0.05, 0.1]:
        tl.push("imu", block(t0))
    assert len(data(drain(tl))) == 3


def test_clock_jump_back_is_rebased_so_the_stream_continues():
    tl = Timeline(TimelineConfig(clock_jump=5.0, reorder_window=0.0))
    times = [100.0, 100.1, 100.2, 3.0, 3.1, 3.2]  # device reset its clock to ~3 s
    for t in times:
        tl.push("s", gt(t, x=t))
    out = drain(tl)
    got = data(out)
    np.testing.assert_allclose(got, [100.0, 100.1, 100.2, 100.3, 100.4, 100.5], atol=1e-9)
    assert tl.stats.counts["timeline"]["clock_jumps"] == 1
    assert [m.code for _, m in out if isinstance(m, Diagnostic)] == ["clock_jump"]


def test_clock_jump_forward_is_detected_from_receive_times():
    tl = Timeline(TimelineConfig(clock_jump=5.0, reorder_window=0.0))
    for t, recv in [(10.0, 1000.0), (10.1, 1000.1), (510.2, 1000.2), (510.3, 1000.3)]:
        tl.push("s", gt(t, x=t), t_recv=recv)
    np.testing.assert_allclose(data(drain(tl)), [10.0, 10.1, 10.2, 10.3], atol=1e-9)


def test_a_real_gap_is_kept_and_reported_not_rebased():
    tl = Timeline(TimelineConfig(gap=2.0, reorder_window=0.0))
    for t, recv in [(0.0, 50.0), (0.1, 50.1), (30.0, 80.0)]:  # silent for 30 s, both clocks agree
        tl.push("s", gt(t, x=t), t_recv=recv)
    out = drain(tl)
    assert data(out) == [0.0, 0.1, 30.0]
    assert [m.code for _, m in out if isinstance(m, Diagnostic)] == ["gap"]


def test_clock_jump_drop_rule_discards_until_time_catches_up():
    tl = Timeline(TimelineConfig(clock_jump=5.0, on_clock_jump="drop", reorder_window=0.0))
    for t in [100.0, 100.1, 1.0, 2.0, 100.05, 100.2]:
        tl.push("s", gt(t, x=t))
    assert data(drain(tl)) == [100.0, 100.1, 100.2]
    assert tl.stats.counts["timeline"]["clock_jump_dropped"] == 2


def test_nan_times_are_refused_and_counted():
    tl = Timeline()
    tl.push("s", gt(float("nan")))
    assert drain(tl) == []
    assert tl.stats.counts["timeline"]["bad_time"] == 1


def test_ticks_fall_on_multiples_of_the_period_between_messages():
    tl = Timeline(TimelineConfig(reorder_window=0.0))
    tl.add_tick(0.5, "ticks.0.5")
    for t in [0.2, 0.9, 2.1]:
        tl.push("s", gt(t, x=t))
    out = drain(tl)
    seq = [(type(m).__name__, m.t) for _, m in out]
    assert seq == [("GroundTruth", 0.2), ("Tick", 0.5), ("GroundTruth", 0.9), ("Tick", 1.0),
                   ("Tick", 1.5), ("Tick", 2.0), ("GroundTruth", 2.1)]


def test_ticks_do_not_drift_over_long_runs():
    tl = Timeline(TimelineConfig(reorder_window=0.0, max_lead=1e5))  # one 10000 s step
    tl.add_tick(0.1, "t")
    tl.push("s", gt(0.0))
    tl.push("s", gt(10000.0, x=1))
    ticks = [m.t for _, m in drain(tl) if isinstance(m, Tick)]
    assert len(ticks) == 100001
    assert ticks[-1] == pytest.approx(10000.0, abs=1e-9)
    assert ticks[77777] == 77777 * 0.1


def test_output_is_deterministic():
    def run():
        tl = Timeline(TimelineConfig(reorder_window=0.3))
        rng = np.random.default_rng(3)
        out = []
        for i in range(200):
            tl.push(f"s{i % 3}", gt(float(rng.uniform(0, 20)), device=f"d{i % 3}", x=i))
            out += tl.release()
        out += tl.release(flush=True)
        return [(s, m.t, float(getattr(m, "position", [0])[0])) for s, m in out]
    assert run() == run()


def test_event_streams_are_not_reported_as_gaps():
    from firenav_framework.messages import TagDetection
    tl = Timeline(TimelineConfig(gap=2.0, reorder_window=0.0))
    for t in [0.0, 40.0, 95.0]:  # tag reads minutes apart are normal
        tl.push("rfid", TagDetection(t=t, agent="a", tag_id=f"tag{t}"))
    out = drain(tl)
    assert data(out) == [0.0, 40.0, 95.0]
    assert not [m for _, m in out if isinstance(m, Diagnostic)]


def test_raw_frames_are_duplicates_only_when_every_field_is_equal():
    from firenav_framework.messages import RawFrame

    def frame(t=1.0, data=b"\x01\x02", recv=10.0):
        return RawFrame(t=t, device="can0", transport="can", channel=0x101, data=data,
                        t_recv=recv)
    tl = Timeline()
    for f in [frame(), frame(), frame(data=b"\x01\x03"), frame(recv=10.5), frame(t=1.01)]:
        tl.push("can.raw", f)
    assert len(data(drain(tl))) == 4    # only the exact copy goes
    assert tl.stats.counts["timeline"]["duplicates"] == 1
