"""The tilt-time ramp as a user sees it in a trial (``--tilt-time``; docs/simulator.md, "The tilt's
own motion"): the tray reaches the full tilt when the ramp ends, and the rest test and the time
limit ``max_time_s`` start there. An Allen key under static/kinetic friction 0.5/0.3 (static
angle atan 0.5 = 26.57 degrees) does not move at all below that slope and slides to the downhill
wall above it."""
from __future__ import annotations

import pytest

from transition_builder.scene import scene_from_options
from transition_builder.sim import TraySimulator, ramp_fractions
from transition_builder.status import OK, UNSETTLED

START = [60.0, 80.0, 0.3]
#: "did not move" (mm, rad): the free base's pose goes through a quaternion and Bullet's integrator
#: each step, so a part held by static friction ends 1e-10 mm and 3e-16 rad from its start, not at it
STILL = 1e-6


def _tilt(**kw):
    sc = scene_from_options("allen-key", "0.5/0.3", **kw)
    with TraySimulator(sc) as sim:
        rest, status = sim.tilt([START], "E")
    return [float(v) for v in rest[0]], int(status[0])


def test_the_tray_reaches_the_full_tilt_after_a_ramp_whose_last_interval_is_short_of_it():
    """A 30-degree tilt in 0.03 s, 1.8 rest-test intervals of 1/60 s: the ramp's two intervals take
    5/18 and 15/18 of the tilt (25 degrees, below the static angle), then the full tilt. The key
    stays put on a 25-degree tray and slides to the east wall (x > 150 mm) once the tray is at 30."""
    dt = scene_from_options("allen-key", "0.5/0.3").settings.check_interval_s
    assert dt == pytest.approx(1 / 60)
    assert ramp_fractions(0.03, dt).tolist() == pytest.approx([5 / 18, 15 / 18, 1.0], abs=1e-12)
    assert _tilt(tilt_deg=25.0) == (pytest.approx(START, abs=STILL), OK)  # the last ramp slope alone: no motion
    rest, status = _tilt(tilt_deg=30.0, tilt_time_s=0.03)
    assert status == OK and rest[0] > 150.0


@pytest.mark.parametrize("tilt_time_s", [0.0, 0.03, 0.5])
def test_the_time_limit_and_the_rest_test_start_when_the_ramp_ends(tilt_time_s):
    """On a 20-degree tray the key never moves, so it is still in every rest-test interval from the
    ramp's end on: with ``max_time_s = dwell_s`` (the least the settings allow) the trial has exactly
    the dwell's intervals after the ramp and settles where it started, whatever the tilt time."""
    rest, status = _tilt(tilt_deg=20.0, tilt_time_s=tilt_time_s, max_time_s=0.05, dwell_s=0.05)
    assert (rest, status) == (pytest.approx(START, abs=STILL), OK)


def test_a_part_still_moving_when_the_time_limit_ends_is_unsettled():
    """The same limit on a 30-degree tray: the key is still sliding after 0.05 s, so it is unsettled
    (the limit is a limit, not a minimum)."""
    assert _tilt(tilt_deg=30.0, tilt_time_s=0.03, max_time_s=0.05, dwell_s=0.05)[1] == UNSETTLED
