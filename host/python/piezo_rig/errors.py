"""The board's refusals as exceptions, one per protocol error code
(docs/protocol.md, "Errors"), and the client's own failures. Each keeps
its fields through pickling, so a worker process can send it back:

>>> import pickle
>>> from piezo_rig.errors import OutOfLimits
>>> refused = OutOfLimits("start", "V0", "95 V is above V_max 80 V")
>>> again = pickle.loads(pickle.dumps(refused))
>>> str(again), again.key, isinstance(again, ValueError)
('start: out_of_limits (V0): 95 V is above V_max 80 V', 'V0', True)
"""

from __future__ import annotations

from ._wire import ErrorCode, Key
from typing import Any


class BoardError(Exception):
    """A request the board refused. ``code`` is the protocol's error code,
    ``key`` the argument at fault (or ""), ``message`` the board's words."""

    code = ""

    def __init__(self, command: str, key: str, message: str, code: str = ""):
        self.command, self.key, self.message = command, key, message
        if code:
            self.code = code
        where = f" ({key})" if key else ""
        # The board's message may begin with the command already ("stop: ...").
        text = message[len(command) + 2:] if message.startswith(command + ": ") else message
        super().__init__(f"{command}: {self.code}{where}: {text}")

    def __reduce__(self) -> tuple[Any, ...]:
        # Pickled by its fields (a worker process sends it back whole).
        return (type(self), (self.command, self.key, self.message, self.code))


class Malformed(BoardError):
    code = ErrorCode.malformed


class TooLarge(BoardError):
    code = ErrorCode.too_large


class UnknownCommand(BoardError):
    code = ErrorCode.unknown_command


class BadArgument(BoardError, ValueError):
    code = ErrorCode.bad_argument


class OutOfLimits(BoardError, ValueError):
    code = ErrorCode.out_of_limits


class BadState(BoardError):
    code = ErrorCode.bad_state


class FaultLatched(BoardError):
    code = ErrorCode.fault_latched


class NotController(BoardError):
    code = ErrorCode.not_controller


class NotAvailable(BoardError):
    code = ErrorCode.not_available


class RateLimited(BoardError):
    code = ErrorCode.rate_limited


class Internal(BoardError):
    code = ErrorCode.internal


class StaleBoard(BoardError):
    """The request named a board start that is gone: the board restarted
    since this client asked ``hello``, and did nothing. The ``Board`` has
    dropped what it knew of the old one (limits, axes, zero, dictionary);
    its next request reads them again."""
    code = ErrorCode.stale_board


ERRORS = {cls.code: cls for cls in (Malformed, TooLarge, UnknownCommand, BadArgument, OutOfLimits,
                                    BadState, FaultLatched, NotController, NotAvailable,
                                    RateLimited, Internal, StaleBoard)}


def board_error(command: str, error: dict[str, Any]) -> BoardError:
    """The exception for an error reply's ``error`` map (an unknown code, from
    a newer board, is a plain BoardError carrying it)."""
    code = error.get(Key.code, "")
    cls = ERRORS.get(code, BoardError)
    return cls(command, error.get(Key.key, "") or "", error.get(Key.message, ""), code)


class NoReply(TimeoutError):
    """The board did not answer in time (it is down, or the link is). The
    request was discarded with the socket that held it: it never reaches
    the board later."""


class ClientClosed(RuntimeError):
    """A request through a ``Board`` (or a run of it) that was closed."""


class RunEnded(RuntimeError):
    """A run or move ended by a stop cause other than the one asked for.
    ``cause`` is the run's stop cause, ``summary`` its summary map."""

    def __init__(self, what: str, cause: str, summary: dict[str, Any]):
        self.what, self.cause, self.summary = what, cause, summary
        super().__init__(f"{what} ended: {cause}")

    def __reduce__(self) -> tuple[Any, ...]:
        return (type(self), (self.what, self.cause, self.summary))
