"""Error types a user can cause, each turned into one line and exit status 2 by the CLI."""

from __future__ import annotations


class DurerError(Exception):
    """Base class of every error durer reports to a user (never a bug in durer itself)."""


class SceneError(DurerError):
    """A scene or mesh file is malformed; carries the file and 1-based line for a `file:line: message` report."""

    def __init__(self, message: str, path: str | None = None, line: int | None = None):
        self.message = message
        self.path = path
        self.line = line
        super().__init__(str(self))

    def __str__(self) -> str:
        if self.path is None:
            return self.message
        if self.line is None:
            return f"{self.path}: {self.message}"
        return f"{self.path}:{self.line}: {self.message}"


class UsageError(DurerError):
    """A bad command-line flag or option value."""


class MissingDependency(DurerError, ImportError):
    """An optional package a requested feature needs is not installed (the message says what to install)."""
