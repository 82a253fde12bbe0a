"""Latched alarms: raised by a condition, kept through silence and return to normal,
closed only by an acknowledgement; every transition an incident-log diagnostic."""
from __future__ import annotations

import time

from firenav_framework.liveview.alarms import AlarmBook, alarm_diagnostic
from firenav_framework.timefmt import clock_text, wall_text

T0 = 1_764_600_000.0  # a live run's pipeline clock: UNIX seconds
WHERE = {"ff3": (1, (4.0, 2.5))}


def test_alarm_states_raise_return_acknowledge_close():
    book = AlarmBook()
    (ev,) = book.update([("ff3", "man_down", True)], T0, WHERE)
    alarm = ev.alarm
    assert (ev.kind, alarm.state, alarm.floor, alarm.position) == \
        ("raised", "unacknowledged", 1, (4.0, 2.5))
    # the condition goes (moving again): still shown, unacknowledged
    (ev,) = book.update([("ff3", "man_down", False)], T0 + 20, WHERE)
    assert (ev.kind, alarm.state) == ("returned", "returned")
    assert book.shown() == [alarm]
    # it comes back before anyone acknowledged: the same alarm again, not a second one
    (ev,) = book.update([("ff3", "man_down", True)], T0 + 30, WHERE)
    assert (ev.kind, alarm.state, alarm.raises, len(book.alarms)) == \
        ("raised_again", "unacknowledged", 2, 1)
    # acknowledged while active: shown (muted) until the condition goes, then closed
    ack = book.acknowledge(alarm.id, T0 + 40, T0 + 40.2, by="IC Berger", client="127.0.0.1")
    assert ack.kind == "acknowledged" and alarm.state == "acknowledged"
    assert book.acknowledge(alarm.id, T0 + 41, T0 + 41) == "alarm 1 was acknowledged already"
    assert book.acknowledge(99, T0 + 41, T0 + 41) == "there is no alarm 99"
    (ev,) = book.update([("ff3", "man_down", False)], T0 + 50, WHERE)
    assert (ev.kind, alarm.state, book.shown()) == ("closed", "closed", [])
    # the next man-down is a new alarm
    (ev,) = book.update([("ff3", "man_down", True)], T0 + 60, WHERE)
    assert ev.alarm.id == 2 and len(book.alarms) == 2


def test_returned_alarm_acknowledged_closes_and_unacknowledged_come_first():
    book = AlarmBook()
    a = book.update([("ff1", "device_silent", True)], 10.0, {})[0].alarm
    b = book.update([("ff2", "untrusted", True)], 20.0, {})[0].alarm
    c = book.update([("ff3", "man_down", True)], 30.0, {})[0].alarm
    book.acknowledge(c.id, 31.0, T0)
    assert [x.id for x in book.shown()] == [b.id, a.id, c.id]  # newest unacknowledged first
    book.update([("ff1", "device_silent", False)], 40.0, {})
    ev = book.acknowledge(a.id, 41.0, T0 + 1)
    assert a.state == "closed" and ev.alarm is a
    assert [x.id for x in book.shown()] == [b.id, c.id]


def test_incident_log_texts_use_the_local_clock_never_epoch_seconds():
    book = AlarmBook()
    raised = book.update([("ff3", "man_down", True)], T0, WHERE)[0]
    d = alarm_diagnostic(raised, "view")
    assert (d.code, d.level, d.active, d.agent, d.component) == \
        ("alarm_man_down", "error", True, "ff3", "view")
    assert d.text == (f"ALARM ff3 MAN DOWN since {wall_text(T0)} at floor 1, (4.0, 2.5) m; "
                      "latched until acknowledged [alarm 1]")
    clicked = T0 + 75.25
    ack = book.acknowledge(1, T0 + 76, clicked, by="IC Berger", client="10.0.0.7")
    d = alarm_diagnostic(ack, "view")
    assert (d.code, d.level, d.active) == ("alarm_acknowledged", "info", True)
    assert f"acknowledged at {wall_text(clicked, date=True)} by 'IC Berger' from 10.0.0.7" \
        in d.text
    for ev in [raised, ack, *book.update([("ff3", "man_down", False)], T0 + 90, WHERE)]:
        text = alarm_diagnostic(ev, "view").text
        assert str(int(T0)) not in text and "1764" not in text, text
    # the same rule in a simulation: seconds from the start
    sim = AlarmBook().update([("ff1", "untrusted", True)], 12.25, {})[0]
    assert "since t=12.2 s" in alarm_diagnostic(sim, "view").text


def test_clock_text_rule():
    assert clock_text(12.25) == "t=12.2 s"
    assert clock_text(float("nan")) == "t=?"
    assert clock_text(T0) == time.strftime("%H:%M:%S", time.localtime(T0))
    assert clock_text(T0, date=True) == time.strftime("%Y-%m-%d %H:%M:%S", time.localtime(T0))
