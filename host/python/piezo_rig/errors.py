"""The board's refusals as exceptions, one per protocol error code
(docs/protocol.md, "Errors"), and the client's own failures."""

from __future__ import annotations


class BoardError(Exception):
    """A request the board refused. ``code`` is the protocol's error code,
    ``key`` the argument at fault (or ""), ``message`` the board's words."""

    code = ""

    def __init__(self, command: str, key: str, message: str):
        self.command, self.key, self.message = command, key, message
        where = f" ({key})" if key else ""
        super().__init__(f"{command}: {self.code}{where}: {message}")


class Malformed(BoardError):
    code = "malformed"


class TooLarge(BoardError):
    code = "too_large"


class UnknownCommand(BoardError):
    code = "unknown_command"


class BadArgument(BoardError, ValueError):
    code = "bad_argument"


class OutOfLimits(BoardError, ValueError):
    code = "out_of_limits"


class BadState(BoardError):
    code = "bad_state"


class FaultLatched(BoardError):
    code = "fault_latched"


class NotController(BoardError):
    code = "not_controller"


class NotAvailable(BoardError):
    code = "not_available"


class RateLimited(BoardError):
    code = "rate_limited"


class Internal(BoardError):
    code = "internal"


ERRORS = {cls.code: cls for cls in (Malformed, TooLarge, UnknownCommand, BadArgument, OutOfLimits,
                                    BadState, FaultLatched, NotController, NotAvailable,
                                    RateLimited, Internal)}


def board_error(command: str, error: dict) -> BoardError:
    """The exception for an error reply's ``error`` map (an unknown code, from
    a newer board, is a plain BoardError carrying it)."""
    code = error.get("code", "")
    cls = ERRORS.get(code)
    if cls is None:
        cls = type("BoardError_" + code, (BoardError,), {"code": code})
    return cls(command, error.get("key", "") or "", error.get("message", ""))


class NoReply(TimeoutError):
    """The board did not answer in time (it is down, or the link is)."""


class RunEnded(RuntimeError):
    """A run or move ended by a stop cause other than the one asked for.
    ``cause`` is the run's stop cause, ``summary`` its summary map."""

    def __init__(self, what: str, cause: str, summary: dict):
        self.cause, self.summary = cause, summary
        super().__init__(f"{what} ended: {cause}")
