"""The job, frame and tile state machines (argand.farm.states) on their own:
each allowed change is allowed, everything else is refused with a message
that names both states and what is allowed."""

from __future__ import annotations

import itertools

import pytest

from argand.farm.states import ACTIONS, ACTIVE, ENDED, FRAME, JOB, STOPPED, TILE, IllegalTransition

ALLOWED = {
    "job": {("queued", "running"), ("queued", "paused"), ("queued", "canceled"), ("queued", "failed"), ("queued", "done"),
          ("running", "paused"), ("running", "canceled"), ("running", "failed"), ("running", "done"),
          ("paused", "queued"), ("paused", "running"), ("paused", "canceled"), ("paused", "failed"), ("paused", "done"),
          ("failed", "queued"), ("failed", "running"), ("failed", "canceled"),
          ("canceled", "queued"), ("canceled", "running")},
    "frame": {("queued", "rendering"), ("queued", "assembling"), ("queued", "done"), ("rendering", "assembling"),
            ("rendering", "done"), ("assembling", "done"), ("assembling", "rendering")},
    "tile": {("queued", "running"), ("running", "done"), ("running", "queued"), ("running", "failed"), ("failed", "queued")},
}


@pytest.mark.parametrize("machine", [JOB, FRAME, TILE], ids=lambda m: m.name)
def test_exactly_the_listed_changes_are_allowed(machine):
    for old, new in itertools.product(machine.states, repeat=2):
        if (old, new) in ALLOWED[machine.name]:
            assert machine.check(old, new) == new and machine.step(old, new) == old
        else:
            assert not machine.allowed(old, new)
            with pytest.raises(IllegalTransition, match=f"a {machine.name} cannot go from {old} to {new}"):
                machine.check(old, new)


@pytest.mark.parametrize("machine", [JOB, FRAME, TILE], ids=lambda m: m.name)
def test_sources_are_the_states_that_may_change_to_a_state(machine):
    for new in machine.states:
        assert set(machine.sources(new)) == {o for o, n in ALLOWED[machine.name] if n == new}
    assert machine.final("done") and machine.sources("done", among=("done",)) == ()


def test_unknown_states_are_refused_naming_the_states():
    with pytest.raises(IllegalTransition, match="unknown tile state: 'lost'; states: queued, running, done, failed"):
        TILE.check("lost", "queued")
    with pytest.raises(IllegalTransition, match="unknown job state 'finished'"):
        JOB.sources("finished")
    with pytest.raises(IllegalTransition, match="from done it may go to: nothing"):
        JOB.check("done", "canceled")


def test_actions_lead_where_the_machine_allows():
    for action, (applies_to, target) in ACTIONS.items():
        assert applies_to, action
        for state in applies_to:
            assert JOB.allowed(state, target), (action, state)
            if target == "queued":  # a started job resumes as running
                assert JOB.allowed(state, "running"), (action, state)
    assert "done" not in ACTIONS["cancel"][0] and set(ACTIONS["pause"][0]) == set(ACTIVE)
    assert set(ACTIVE) | set(STOPPED) | {"done"} == set(JOB.states) and set(ENDED) <= set(JOB.states)
