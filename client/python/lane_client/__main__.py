"""A small command line over LaneClient:

    python3 -m lane_client health  [--target T]
    python3 -m lane_client session list | get CAMERA | create CAMERA CONFIG [--replace]
                                       | delete CAMERA
    python3 -m lane_client detect  CAMERA FRAME [--config CONFIG]

Answers are printed as JSON (the messages' proto3 JSON form). Exit 0 on
success, 1 when the call failed (the reason on stderr), 2 for a usage error
(also a CAMERA the server would refuse: 1 to 128 characters of
[A-Za-z0-9._:/-]).
The token comes from --token-file or $LANE_TOKEN, as for lane-client.
"""

import argparse
import json
import sys
from typing import List, Optional

from . import __version__
from .camera_id import check_camera_id
from .errors import LaneError

HEALTH_CHECK = "/grpc.health.v1.Health/Check"
# grpc.health.v1.HealthCheckResponse.ServingStatus
HEALTH_STATUS = {0: "UNKNOWN", 1: "SERVING", 2: "NOT_SERVING", 3: "SERVICE_UNKNOWN"}


def _health_status(response: bytes) -> str:
    """The `status` (field 1, an enum) of a serialized HealthCheckResponse."""
    status = 0  # proto3: an absent field is 0
    i = 0
    while i < len(response):
        key = response[i]
        i += 1
        value, shift = 0, 0
        while i < len(response):
            byte = response[i]
            i += 1
            value |= (byte & 0x7F) << shift
            shift += 7
            if not byte & 0x80:
                break
        if key == 0x08:  # field 1, varint
            status = value
    return HEALTH_STATUS.get(status, str(status))


def _to_json(message) -> str:
    from google.protobuf import json_format
    return json_format.MessageToJson(message, indent=None, preserving_proto_field_name=True)


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="python3 -m lane_client",
                                     description="Calls lane-server (lane.v1.LaneService).")
    parser.add_argument("--version", action="version", version=f"lane_client {__version__}")
    parser.add_argument("--target", default="127.0.0.1:50051", help="server (host:port)")
    parser.add_argument("--token-file", help="Bearer token: the first line of FILE "
                        "(default: $LANE_TOKEN)")
    parser.add_argument("--ca", help="PEM file of the CA that signed the server's "
                        "certificate: TLS (default: plaintext)")
    parser.add_argument("--timeout", type=float, default=10.0, help="seconds per call")
    commands = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    commands.add_parser("health", help="the server's gRPC health (SERVING: exit 0)")
    session = commands.add_parser("session", help="list, get, create or delete sessions")
    actions = session.add_subparsers(dest="action", required=True, metavar="ACTION")
    actions.add_parser("list", help="every session")
    actions.add_parser("get", help="one camera's session").add_argument("camera")
    create = actions.add_parser("create", help="create or confirm a camera's session")
    create.add_argument("camera")
    create.add_argument("config", help="JSON config file (configs/*.json)")
    create.add_argument("--replace", action="store_true", help="replace a different config")
    actions.add_parser("delete", help="delete a camera's session").add_argument("camera")
    detect = commands.add_parser("detect", help="the lanes of one frame file (JPEG, PNG)")
    detect.add_argument("camera")
    detect.add_argument("frame", help="JPEG or PNG file")
    detect.add_argument("--config", help="create or confirm the session with this config first")
    return parser


def main(argv: Optional[List[str]] = None) -> int:
    args = _parser().parse_args(argv)
    if getattr(args, "camera", None) is not None:
        try:
            check_camera_id(args.camera)
        except ValueError as e:
            print(f"lane_client {args.command}: {e}", file=sys.stderr)
            return 2
    token = None
    if args.token_file:
        try:
            with open(args.token_file, encoding="utf-8") as f:
                token = f.readline().strip()
        except OSError as e:
            print(f"lane_client: --token-file {args.token_file}: {e.strerror}", file=sys.stderr)
            return 2
    from .client import LaneClient
    try:
        with LaneClient(args.target, token=token, ca=args.ca, timeout=args.timeout) as client:
            if args.command == "health":
                check = client.channel.unary_unary(HEALTH_CHECK)
                status = _health_status(check(b"", timeout=args.timeout))
                print(json.dumps({"target": args.target, "status": status}))
                return 0 if status == "SERVING" else 1
            if args.command == "detect":
                response = client.detect(args.camera, args.frame, config=args.config)
                print(_to_json(response))
                return 0
            if args.action == "list":
                for session in client.list_sessions():
                    print(_to_json(session))
            elif args.action == "get":
                print(_to_json(client.get_session(args.camera)))
            elif args.action == "create":
                print(_to_json(client.create_session(args.camera, args.config,
                                                     replace=args.replace)))
            else:
                client.delete_session(args.camera)
                print(json.dumps({"deleted": args.camera}))
            return 0
    except LaneError as e:
        print(f"lane_client {args.command}: {e}", file=sys.stderr)
        return 1
    except Exception as e:  # grpc.RpcError of the health call, an unreadable file
        code = e.code().name if hasattr(e, "code") and callable(e.code) else type(e).__name__
        details = e.details() if hasattr(e, "details") and callable(e.details) else str(e)
        print(f"lane_client {args.command}: {code}: {details}", file=sys.stderr)
        return 1


if __name__ == "__main__":
    sys.exit(main())
