"""Compute slots: worker processes that compute only while they hold a slot."""

from __future__ import annotations

import threading
import time

import pytest

from simplexspline import _compute_slots as slots


@pytest.fixture
def one_slot(monkeypatch):
    gate = threading.BoundedSemaphore(1)
    monkeypatch.setattr(slots, "_GATE", gate)
    monkeypatch.setattr(slots, "_BUSY", 0.0)
    monkeypatch.setattr(slots, "_DEPTH", 0)
    return gate


def test_a_slot_is_held_for_the_block_reentrantly_and_released(one_slot):
    with slots.compute_slot():
        assert not one_slot.acquire(blocking=False)        # taken
        with slots.compute_slot():                          # nested: no deadlock
            time.sleep(0.05)
        assert not one_slot.acquire(blocking=False)        # still taken
        inside = slots.busy_seconds()
    assert one_slot.acquire(blocking=False)                 # released
    one_slot.release()
    total = slots.busy_seconds()
    assert 0.05 <= inside <= total < 5.0                    # counts the current hold too


def test_a_slot_is_released_when_the_block_raises(one_slot):
    with pytest.raises(ValueError, match="inside"):
        with slots.compute_slot():
            raise ValueError("inside")
    assert one_slot.acquire(blocking=False)
    one_slot.release()


def test_without_slots_nothing_waits_and_wall_time_counts(monkeypatch):
    monkeypatch.setattr(slots, "_GATE", None)
    with slots.compute_slot():
        pass
    assert slots.busy_seconds() is None
