"""Exceptions of lane_client. Every one is a LaneError.

A failed call raises the LaneError subclass that fits its gRPC status, with
the status in `.code` (a grpc.StatusCode, or None when no call was made) and
the server's message in `.details`; the original grpc.RpcError is the
exception's __cause__.
"""


class LaneError(Exception):
    """A call to lane-server failed, or the client could not make it."""

    def __init__(self, message, code=None, details=""):
        super().__init__(message)
        self.code = code
        self.details = details


class StubsNotFoundError(LaneError, ImportError):
    """The generated modules are missing: run `python3 -m lane_client.generate`."""


class SessionNotFoundError(LaneError):
    """The server has no session for the camera (NOT_FOUND, or FAILED_PRECONDITION
    for a frame): create it with create_session(), or pass config= ."""


class InvalidFrameError(LaneError):
    """Detect(): the frame was refused (INVALID_ARGUMENT: not a JPEG/PNG, a
    wrong size or pixel format, ...)."""


class UnauthenticatedError(LaneError):
    """The server wants a Bearer token (token=...) and got none or a wrong one."""


class StreamError(LaneError):
    """stream(): the stream gave up: a permanent status, the same status code
    after max_reconnects reconnections in a row, or no frame answered within
    give_up_after seconds. `.code` and `.details` are the status code and
    message of the last failure (UNAVAILABLE and "Socket closed", say, not a
    code of the client's own); `.failures` lists why each call ended."""

    def __init__(self, message, code=None, details="", failures=()):
        super().__init__(message, code, details)
        self.failures = list(failures)


def from_rpc_error(error, what):
    """The LaneError for a grpc.RpcError raised by call `what` (e.g. 'Detect')."""
    import grpc  # only imported where a call was made

    code = error.code() if hasattr(error, "code") else None
    details = (error.details() if hasattr(error, "details") else "") or ""
    name = code.name if code is not None else "UNKNOWN"
    message = f"{what}: {name}: {details}" if details else f"{what}: {name}"
    if code == grpc.StatusCode.NOT_FOUND or (
            code == grpc.StatusCode.FAILED_PRECONDITION and "no session" in details):
        cls = SessionNotFoundError
    elif code == grpc.StatusCode.INVALID_ARGUMENT and what == "Detect":
        cls = InvalidFrameError
    elif code == grpc.StatusCode.UNAUTHENTICATED:
        cls = UnauthenticatedError
    else:
        cls = LaneError
    return cls(message, code, details)
