"""Python client of lane-server (lane.v1.LaneService, proto/lane/v1/lane_service.proto).

    from lane_client import LaneClient

    with LaneClient("127.0.0.1:50051") as client:
        client.create_session("cam0", "configs/synthetic.json")
        response = client.detect("cam0", open("frame.jpg", "rb").read())
        for lane in response.lanes:
            print(lane.score, [(p.x, p.y) for p in lane.image.control_points])
        for response in client.stream("cam0", frames):   # frames: bytes or numpy arrays
            ...

Needs Debian's python3-grpcio and python3-protobuf (python3-numpy for array
frames), and stubs generated once from the proto: `python3 -m
lane_client.generate` (see client/python/README.md).

Modules: client (LaneClient), streaming (FrameStream: the reconnecting
stream), aio (AsyncLaneClient, AsyncFrameStream: the same over asyncio),
frames (what a frame may be), errors (LaneError and subclasses), generate
(the stubs), reflection (a grpcurl-like command line); `python3 -m
lane_client --help`: health, sessions and detection from the shell.
"""

from .errors import (InvalidFrameError, LaneError, SessionNotFoundError, StreamError,
                     StubsNotFoundError, UnauthenticatedError)


def _find_version() -> str:
    """The project's version (the file VERSION at the repository's root):
    written into the built package by setup.py, else read from the checkout
    this package sits in."""
    try:
        from ._version import __version__ as built
        return built
    except ImportError:
        pass
    import os
    root = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "..")
    try:
        with open(os.path.join(root, "VERSION"), encoding="utf-8") as f:
            return f.readline().strip()
    except OSError:
        return "unknown"


__version__ = _find_version()

__all__ = [
    "LaneClient", "FrameStream", "AsyncLaneClient", "AsyncFrameStream", "load_stubs", "LaneError", "InvalidFrameError",
    "SessionNotFoundError", "StreamError", "StubsNotFoundError", "UnauthenticatedError",
]


def load_stubs():
    """(lane_service_pb2, lane_service_pb2_grpc): the generated modules, for
    the message classes and enums (e.g. pb2.FRAME_CODE_INVALID_ARGUMENT)."""
    from . import _stubs
    return _stubs.load()


def __getattr__(name):
    # Imported on first use, so that `python3 -m lane_client.generate` runs
    # before grpc is installed or any stub exists.
    if name == "LaneClient":
        from .client import LaneClient
        return LaneClient
    if name == "FrameStream":
        from .streaming import FrameStream
        return FrameStream
    if name in ("AsyncLaneClient", "AsyncFrameStream"):
        from . import aio
        return getattr(aio, name)
    raise AttributeError(f"module 'lane_client' has no attribute {name!r}")
