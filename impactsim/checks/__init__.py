"""Checks with actions (the case's [checks] table, LS-DYNA style).

Each check watches one condition: initial_penetration (bodies inside each other or behind a
wall at t = 0, overlap.py), negative_volume, time_step_floor, energy_balance, hourglass_share
(generic over a history column that may be absent), unconverged_contact. Its action is `error`
(stop: exit 3, or exit 2 before the first step), `warn` (printed once with its count), `ignore`
(recorded only) or `erode` (remove the element at fault and go on). ``CheckLog`` counts what
triggered, prints each check once, and gives the `checks` table of summary.json.
"""

from __future__ import annotations

from collections.abc import Callable


class CheckFailed(Exception):
    """A check whose action is `error` triggered; the message names the check and the case."""


class CheckLog:
    """What triggered during a run: per check its action, count and first message."""

    def __init__(self, log: Callable[[str], None] | None = None):
        self.log = log or (lambda msg: None)
        self.records: dict[str, dict] = {}

    def trigger(self, name: str, action: str, message: str, count: int = 1) -> str:
        """Record `count` occurrences of check `name`; print it the first time unless ignored;
        raise CheckFailed when the action is `error`. Returns the action."""
        rec = self.records.get(name)
        if rec is None:
            rec = self.records[name] = {"action": action, "count": 0, "first": message}
            if action == "error":
                pass  # the stop message says it
            elif action != "ignore":
                self.log(f"check {name} ({action}): {message}")
        rec["count"] += count
        rec["last"] = message
        if action == "error":
            raise CheckFailed(f"check {name}: {message}")
        return action

    def summary(self) -> dict:
        """The `checks` table of summary.json."""
        return {k: dict(v) for k, v in self.records.items()}

    def closing_lines(self) -> list[str]:
        """One line per check that triggered more than once (its count), for the end of a run."""
        return [f"check {k} ({v['action']}): triggered {v['count']} time(s)"
                for k, v in self.records.items() if v["count"] > 1 and v["action"] != "ignore"]
