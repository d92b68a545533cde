"""Exceptions the CLI turns into exit status 2 with a one-line message."""


class TactileBulletError(Exception):
    """Base class of the project's own errors."""


class UsageError(TactileBulletError, ValueError):
    """Bad input from the user: unknown name, value out of range, unreadable file.

    The CLI prints ``str(error)`` on one line and exits with status 2. Library code raises it
    wherever the cause is the caller's input rather than a bug.
    """
