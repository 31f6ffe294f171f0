"""What a run killed with SIGKILL may leave of history.csv (impactsim/output/history.py)."""

PAGE = 4096  # Linux's page size here: where a write torn by SIGKILL stops


def whole_history(text: str) -> str:
    """The text of a killed run's history.csv up to its last newline. A last line without one
    is accepted only where SIGKILL can tear a write, at a page boundary (Linux stops copying
    there when the signal is pending); a torn line anywhere else fails."""
    if text and not text.endswith("\n"):
        assert len(text.encode()) % PAGE == 0, "a torn last line off a page boundary"
        return text[:text.rfind("\n") + 1]
    return text
