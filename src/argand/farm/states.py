"""The states of jobs, frames and tiles, and the changes allowed between
them: written once here, and every change of state in the farm goes through
:meth:`Machine.check` (an object in hand) or :meth:`Machine.sources` /
:meth:`Machine.step` (the ``WHERE`` of a compare-and-set statement).

Job:   queued -> running -> done; queued|running -> paused -> queued|running
       (resume); any but done -> canceled; failed|canceled|paused -> queued|
       running (retry); a tile failing too often fails its job.
Frame: queued -> rendering -> assembling -> done; a frame rendered whole by
       one worker goes straight to done; an assembler that died sends the
       frame back to rendering.
Tile:  queued -> running -> done; running -> queued (given back) or failed
       (too many attempts); failed -> queued (retry).
"""

from __future__ import annotations

from dataclasses import dataclass


class IllegalTransition(ValueError):
    """A change of state the machine does not allow."""


@dataclass(frozen=True)
class Machine:
    name: str
    #: state -> the states it may change to (a final state maps to nothing).
    transitions: dict[str, frozenset[str]]

    @property
    def states(self) -> tuple[str, ...]:
        return tuple(self.transitions)

    def allowed(self, old: str, new: str) -> bool:
        return new in self.transitions.get(old, ())

    def check(self, old: str, new: str) -> str:
        """Returns ``new`` if ``old -> new`` is allowed; else raises, naming both
        and what ``old`` may become."""
        if old not in self.transitions or new not in self.transitions:
            raise IllegalTransition(f"unknown {self.name} state: {old if old not in self.transitions else new!r}; "
                                    f"states: {', '.join(self.states)}")
        if not self.allowed(old, new):
            may = ", ".join(sorted(self.transitions[old])) or "nothing (final)"
            raise IllegalTransition(f"a {self.name} cannot go from {old} to {new}; from {old} it may go to: {may}")
        return new

    def step(self, old: str, new: str) -> str:
        """``old``, checked to be allowed to become ``new`` (for a WHERE)."""
        self.check(old, new)
        return old

    def sources(self, new: str, among: tuple[str, ...] | None = None) -> tuple[str, ...]:
        """The states that may become ``new`` (limited to ``among``), for the
        WHERE of a compare-and-set."""
        if new not in self.transitions:
            raise IllegalTransition(f"unknown {self.name} state {new!r}; states: {', '.join(self.states)}")
        return tuple(s for s in (among or self.states) if self.allowed(s, new))

    def final(self, state: str) -> bool:
        return not self.transitions[state]


def _machine(name: str, table: dict[str, tuple[str, ...]]) -> Machine:
    return Machine(name, {k: frozenset(v) for k, v in table.items()})


JOB = _machine("job", {
    "queued": ("running", "paused", "canceled", "failed", "done"),
    "running": ("paused", "canceled", "failed", "done"),
    "paused": ("queued", "running", "canceled", "failed", "done"),
    "done": (),
    "failed": ("queued", "running", "canceled"),
    "canceled": ("queued", "running"),
})
FRAME = _machine("frame", {
    "queued": ("rendering", "assembling", "done"),
    "rendering": ("assembling", "done"),
    "assembling": ("done", "rendering"),
    "done": (),
})
TILE = _machine("tile", {
    "queued": ("running",),
    "running": ("done", "queued", "failed"),
    "done": (),
    "failed": ("queued",),
})

#: Jobs whose tiles may still be rendered; jobs whose runs stop between tiles.
ACTIVE = ("queued", "running")
STOPPED = ("canceled", "paused", "failed")
#: A job in one of these states has nothing more to happen to it by itself.
ENDED = ("done", "failed", "canceled")

#: A frame as the API shows it: its own state, except that a frame not done
#: of a job that stopped (canceled, paused, failed) shows the job's state, as
#: nothing renders it (a frame's row keeps "rendering" so that a retry takes
#: it up where it stopped).
FRAME_SHOWN = FRAME.states + STOPPED


def shown_frame_status(job_status: str, frame_status: str) -> str:
    """The state the API gives a frame of a job in ``job_status``."""
    if frame_status != "done" and job_status in STOPPED:
        return job_status
    return frame_status


#: The user's actions on a job: action -> (the job states it applies to, the
#: state it leads to; for resume and retry "queued", or "running" once the
#: job has started). Asked of a job in another state, an action changes nothing.
ACTIONS: dict[str, tuple[tuple[str, ...], str]] = {
    "cancel": (JOB.sources("canceled"), "canceled"),
    "pause": (JOB.sources("paused"), "paused"),
    "resume": (("paused",), "queued"),
    "retry": (("failed", "canceled", "paused"), "queued"),
}
