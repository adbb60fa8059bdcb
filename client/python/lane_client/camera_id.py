"""What a camera id may be: 1 to 128 characters of [A-Za-z0-9._:/-].

The server refuses any other id (INVALID_ARGUMENT; lane-server's rule is in
wire/camera_id.h, and lane-client checks the same). The clients check it
before sending, because the id also travels in the `x-camera-id` header
that a proxy hashes (deploy/nginx), and a proxy may refuse a header the
server never sees: nginx answers a 64 KiB one with GOAWAY
ENHANCE_YOUR_CALM, which a gRPC client sees as UNAVAILABLE "Socket closed"
and would retry.
"""

import re

MAX_CAMERA_ID_CHARS = 128
_CAMERA_ID = re.compile(r"[A-Za-z0-9._:/-]+")


def check_camera_id(camera_id):
    """Returns `camera_id`; raises ValueError when the server would refuse it."""
    if not isinstance(camera_id, str):
        raise ValueError(f"camera_id must be a str, not {type(camera_id).__name__}")
    if not 1 <= len(camera_id) <= MAX_CAMERA_ID_CHARS:
        raise ValueError(f"camera_id must have 1 to {MAX_CAMERA_ID_CHARS} characters, "
                         f"got {len(camera_id)}")
    if not _CAMERA_ID.fullmatch(camera_id):
        shown = camera_id if len(camera_id) <= 48 else camera_id[:48] + "..."
        raise ValueError(f"camera_id {shown!r} has a character outside [A-Za-z0-9._:/-]")
    return camera_id
