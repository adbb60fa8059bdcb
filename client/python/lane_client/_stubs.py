"""Finds and imports the generated lane.v1 modules (see generate.py).

Where they are looked for, first match wins:
  1. $LANE_CLIENT_STUBS, when set (and then only there): a directory made by
     `python3 -m lane_client.generate --out DIR` or by the CMake build
     (BUILD/client-python-stubs);
  2. lane_client/_generated/, the default of `python3 -m lane_client.generate`.

The directory is put first on sys.path and the modules are imported as
lane.v1.lane_service_pb2 and lane.v1.lane_service_pb2_grpc (the names the
generated code itself uses).
"""

import json
import os
import sys
import threading
import warnings

from . import generate as _generate
from .errors import StubsNotFoundError

ENV_VAR = "LANE_CLIENT_STUBS"

_lock = threading.Lock()
_loaded = None


def _candidates():
    env = os.environ.get(ENV_VAR)
    if env:
        return [os.path.abspath(env)]
    return [_generate.default_out_dir()]


def _has_stubs(directory):
    return all(os.path.isfile(os.path.join(directory, "lane", "v1", name))
               for name in ("lane_service_pb2.py", "lane_service_pb2_grpc.py"))


def _warn_if_stale(directory):
    """Warns when the checkout's proto differs from the one the stubs were made from."""
    current = _generate.proto_digest(_generate.default_proto_dir())
    if current is None:
        return  # not in a checkout: nothing to compare with
    try:
        with open(os.path.join(directory, _generate.STAMP_FILE)) as f:
            made_from = json.load(f).get("proto_sha256")
    except (OSError, ValueError):
        made_from = None
    if made_from != current:
        warnings.warn(
            f"lane_client: the stubs in {directory} were not generated from the current "
            f"{_generate.PROTO_FILE}; regenerate them: python3 -m lane_client.generate"
            + (f" --out {directory}" if directory != _generate.default_out_dir() else ""),
            RuntimeWarning, stacklevel=3)


def load():
    """Returns (lane_service_pb2, lane_service_pb2_grpc), importing them once."""
    global _loaded
    with _lock:
        if _loaded is not None:
            return _loaded
        searched = _candidates()
        for directory in searched:
            if not _has_stubs(directory):
                continue
            if directory not in sys.path:
                sys.path.insert(0, directory)
            try:
                from lane.v1 import lane_service_pb2, lane_service_pb2_grpc
            except ImportError as e:
                raise StubsNotFoundError(
                    f"lane_client: importing the stubs in {directory} failed: {e}. "
                    "They need Debian's python3-protobuf and python3-grpcio "
                    "(apt-get install python3-grpcio python3-protobuf)") from e
            _warn_if_stale(directory)
            _loaded = (lane_service_pb2, lane_service_pb2_grpc)
            return _loaded
        where = " or ".join(searched)
        hint = (f"python3 -m lane_client.generate --out {searched[0]}" if os.environ.get(ENV_VAR)
                else "python3 -m lane_client.generate")
        raise StubsNotFoundError(
            f"lane_client: the generated gRPC stubs are missing (looked in {where}). "
            f"Generate them once with: {hint} "
            "(needs Debian's protobuf-compiler and protobuf-compiler-grpc), or set "
            f"{ENV_VAR} to a directory that holds them (a CMake build makes "
            "BUILD/client-python-stubs)")
