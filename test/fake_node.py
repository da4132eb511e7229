"""A stand-in for a ROS node where only its logger is used (NodeState and the like)."""

from __future__ import annotations


class FakeLogger:
    """Keeps every line logged, whatever its level."""

    def __init__(self) -> None:
        self.lines: list[str] = []

    def info(self, line: str) -> None:
        self.lines.append(line)

    warning = info
    error = info


class FakeNode:
    """A node that has a logger and nothing else."""

    def __init__(self) -> None:
        self.logger = FakeLogger()

    def get_logger(self) -> FakeLogger:
        return self.logger
