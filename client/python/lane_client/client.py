"""LaneClient: one channel to a lane-server and the calls of lane.v1.LaneService."""

import json
import os
from typing import Any, Iterable, List, Optional, Sequence, Tuple, Union

import grpc

from . import _stubs
from .camera_id import check_camera_id
from .errors import LaneError, from_rpc_error
from .frames import fill_image
from .streaming import DEFAULT_MAX_RECONNECTS, FrameStream

# As lane-client (client/common.cc): reconnect quickly after a server restart
# (gRPC's own default waits 1 s, then up to 120 s), and keepalive pings during
# calls so that a dead connection is noticed (the server permits one ping
# every 10 s).
_CHANNEL_OPTIONS = [
    ("grpc.initial_reconnect_backoff_ms", 100),
    # gRPC core's shortest connection-attempt deadline, despite the name (as
    # lane-client, client/common.cc: 100 ms timed out behind a busy proxy).
    ("grpc.min_reconnect_backoff_ms", 2000),
    ("grpc.max_reconnect_backoff_ms", 2000),
    ("grpc.keepalive_time_ms", 20000),
    ("grpc.keepalive_timeout_ms", 10000),
    # Raw 4K frames are 25 MB; the server's limit (--max_receive_message_bytes,
    # 32 MiB by default) is the one that counts.
    ("grpc.max_send_message_length", -1),
    ("grpc.max_receive_message_length", 64 * 1024 * 1024),
]


# What a config may be (LaneClient.session_config), and a frame (frames.py).
Config = Union[dict, str, bytes, "os.PathLike[str]", Any]
Image = Union[bytes, str, "os.PathLike[str]", Any]


def session_config(pb2: Any, config: Config) -> Any:
    """A SessionConfig from a dict, a JSON string, a path to a configs/*.json
    file, or a SessionConfig (returned as is); both clients use it."""
    if isinstance(config, pb2.SessionConfig):
        return config
    if isinstance(config, dict):
        return pb2.SessionConfig(config_json=json.dumps(config))
    if isinstance(config, (bytes, bytearray)):
        config = bytes(config).decode("utf-8")
    if isinstance(config, str) and config.lstrip().startswith("{"):
        return pb2.SessionConfig(config_json=config)
    if isinstance(config, (str, os.PathLike)):
        try:
            with open(config, "r", encoding="utf-8") as f:
                return pb2.SessionConfig(config_json=f.read())
        except OSError as e:
            raise LaneError(f"config {os.fspath(config)!r} is neither JSON nor a readable "
                            f"file: {e.strerror}") from e
    raise TypeError("config must be a dict, a JSON string, a path to a JSON config file "
                    f"or a SessionConfig, not {type(config).__name__}")


def channel_credentials(ca: Any, cert: Any, key: Any, server_name: Optional[str],
                        channel_options: List[Tuple[str, Any]]) -> Optional[Any]:
    """TLS credentials for `ca` (and `cert`/`key` for mutual TLS), or None for
    plaintext; adds the name override to `channel_options`. Both clients use it."""
    if ca is None:
        if cert is not None or key is not None:
            raise ValueError("cert and key need ca= (mutual TLS runs over TLS)")
        return None
    if (cert is None) != (key is None):
        raise ValueError("cert and key go together (mutual TLS)")
    if server_name:
        channel_options.append(("grpc.ssl_target_name_override", server_name))
    return grpc.ssl_channel_credentials(
        root_certificates=_read_pem(ca, "CA file"),
        private_key=_read_pem(key, "key file"),
        certificate_chain=_read_pem(cert, "certificate file"))


# The header that names a call's camera, for a proxy's affinity (deploy/nginx).
CAMERA_ID_HEADER = "x-camera-id"


def camera_metadata(metadata: Tuple[Tuple[str, str], ...],
                    camera_id: Optional[str]) -> Tuple[Tuple[str, str], ...]:
    """`metadata` plus the camera id header, when the call has a camera."""
    return metadata + ((CAMERA_ID_HEADER, camera_id),) if camera_id else metadata


def bearer_metadata(token: Optional[str]) -> Tuple[Tuple[str, str], ...]:
    """The metadata for `token` (None: $LANE_TOKEN, as lane-client; "": none)."""
    if token is None:
        token = os.environ.get("LANE_TOKEN", "").strip()
    return (("authorization", f"Bearer {token}"),) if token else ()


def _read_pem(value, what):
    """PEM bytes from bytes, a PEM string, or a path."""
    if value is None:
        return None
    if isinstance(value, (bytes, bytearray)):
        return bytes(value)
    if isinstance(value, str) and value.lstrip().startswith("-----BEGIN"):
        return value.encode()
    try:
        with open(value, "rb") as f:
            return f.read()
    except OSError as e:
        raise LaneError(f"cannot read {what} {value!r}: {e.strerror}") from e


class LaneClient:
    """A client of lane-server's lane.v1.LaneService.

    target: "host:port" (default 127.0.0.1:50051) or any gRPC target URI
        ("dns:///lanes.example:50051", "unix:///run/lane.sock").
    token: Bearer token, sent as `authorization: Bearer TOKEN` metadata on
        every call (server --auth_tokens_file / LANE_AUTH_TOKENS). None: the
        environment variable LANE_TOKEN if set, as lane-client does; "" for
        none at all.
    ca: root CA certificates (a PEM path, or PEM bytes/str): the channel uses
        TLS and verifies the server's certificate against them (it must name
        the host of `target`, or `server_name`). None: plaintext.
    cert, key: client certificate and key for mutual TLS (server
        --tls_client_ca); only with `ca`.
    server_name: the name to verify the server's certificate against, when
        it is not the host of `target` (TLS only).
    timeout: deadline of each unary call, seconds.
    options: extra gRPC channel options, [(name, value), ...].

    Usable as a context manager; close() closes the channel.
    """

    def __init__(self, target: str = "127.0.0.1:50051", token: Optional[str] = None,
                 ca: Any = None, *, cert: Any = None, key: Any = None,
                 server_name: Optional[str] = None, timeout: float = 10.0,
                 options: Optional[Sequence[Tuple[str, Any]]] = None) -> None:
        self.pb2, pb2_grpc = _stubs.load()
        self.target = target
        self.timeout = timeout
        self._metadata = bearer_metadata(token)
        channel_options = list(_CHANNEL_OPTIONS) + list(options or [])
        credentials = channel_credentials(ca, cert, key, server_name, channel_options)
        if credentials is not None:
            self._channel = grpc.secure_channel(target, credentials, options=channel_options)
        else:
            self._channel = grpc.insecure_channel(target, options=channel_options)
        self._stub = pb2_grpc.LaneServiceStub(self._channel)

    # -- plumbing -----------------------------------------------------------

    def close(self) -> None:
        self._channel.close()

    def __enter__(self) -> "LaneClient":
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()

    @property
    def channel(self) -> grpc.Channel:
        """The grpc.Channel (for other services on the same port, e.g. health)."""
        return self._channel

    @property
    def metadata(self) -> Tuple[Tuple[str, str], ...]:
        """The metadata sent with every call (the Bearer token), as gRPC wants it."""
        return self._metadata

    def _call(self, name, request, timeout=None, camera_id=None):
        method = getattr(self._stub, name)
        if camera_id is not None:
            check_camera_id(camera_id)  # ValueError: never sent
        try:
            return method(request, timeout=self.timeout if timeout is None else timeout,
                          metadata=camera_metadata(self._metadata, camera_id))
        except grpc.RpcError as e:
            raise from_rpc_error(e, name) from e

    # -- sessions -----------------------------------------------------------

    def session_config(self, config: Config) -> Any:
        """A SessionConfig from a dict, a JSON string, a path to a configs/*.json
        file, or a SessionConfig (returned as is). The JSON goes to the
        server as `config_json`; the server parses and checks it."""
        return session_config(self.pb2, config)

    def create_session(self, camera_id: str, config: Config, *, replace: bool = False,
                       timeout: Optional[float] = None) -> Any:
        """Creates the camera's session, or confirms it (CreateSession).

        Returns the CreateSessionResponse: `.session` (version, resolved
        config) and `.outcome` (CREATE_OUTCOME_CREATED, _UNCHANGED for the
        same config again, _REPLACED with replace=True). A different config
        without replace raises LaneError with code ALREADY_EXISTS.
        """
        request = self.pb2.CreateSessionRequest(camera_id=camera_id,
                                                config=self.session_config(config),
                                                replace=replace)
        return self._call("CreateSession", request, timeout, camera_id)

    def get_session(self, camera_id: str, *, timeout: Optional[float] = None) -> Any:
        """The Session of a camera; SessionNotFoundError when there is none."""
        return self._call("GetSession", self.pb2.GetSessionRequest(camera_id=camera_id), timeout,
                          camera_id)

    def list_sessions(self, *, timeout: Optional[float] = None) -> List[Any]:
        """All sessions, sorted by camera id (a list of Session)."""
        return list(self._call("ListSessions", self.pb2.ListSessionsRequest(), timeout).sessions)

    def delete_session(self, camera_id: str, *, timeout: Optional[float] = None) -> None:
        """Deletes a camera's session; SessionNotFoundError when there is none."""
        self._call("DeleteSession", self.pb2.DeleteSessionRequest(camera_id=camera_id), timeout,
                   camera_id)

    def server_info(self, *, timeout: Optional[float] = None) -> Any:
        """ServerInfo: version, build, formats, limits and detector defaults."""
        return self._call("GetServerInfo", self.pb2.GetServerInfoRequest(), timeout)

    # -- frames -------------------------------------------------------------

    def frame_request(self, camera_id: str, image: Image, *, frame_id: int = 0,
                      capture_time_unix_ns: int = 0, rgb: bool = False) -> Any:
        """The FrameRequest for `image` (see lane_client.frames for what it may be)."""
        request = self.pb2.FrameRequest(camera_id=camera_id, frame_id=frame_id,
                                        capture_time_unix_ns=capture_time_unix_ns)
        return fill_image(request, image, self.pb2, rgb=rgb)

    def detect(self, camera_id: str, image: Image, *, frame_id: int = 0,
               capture_time_unix_ns: int = 0, rgb: bool = False, config: Optional[Config] = None,
               replace: bool = False, timeout: Optional[float] = None) -> Any:
        """Detects the lanes of one frame (unary Detect) and returns the
        FrameResponse: `.lanes` (each with `.image`, `.ipm`, `.ground` Bezier
        curves of 4 `.control_points`, and `.score`), `.timings`, ...

        image: JPEG/PNG bytes or a path (sent encoded), or a numpy uint8
            array H x W x 3 BGR (rgb=True: RGB) or H x W grey (sent raw).
        config: create or confirm the session first, in the same call.
        Raises InvalidFrameError for a frame the server refuses,
        SessionNotFoundError for a camera without a session, LaneError else.
        """
        request = self.frame_request(camera_id, image, frame_id=frame_id,
                                     capture_time_unix_ns=capture_time_unix_ns, rgb=rgb)
        if config is not None:
            request.session_config.CopyFrom(self.session_config(config))
            request.replace_session = replace
        return self._call("Detect", request, timeout, camera_id)

    def stream(self, camera_id: str, frames: Iterable[Any], *, config: Optional[Config] = None,
               replace: bool = False, window: int = 8, first_frame_id: int = 0,
               rgb: bool = False, reconnect: bool = True, give_up_after: float = 60.0,
               stall_timeout: Optional[float] = 30.0,
               max_reconnects: Optional[int] = DEFAULT_MAX_RECONNECTS) -> FrameStream:
        """Streams frames (StreamFrames) and returns a FrameStream: an
        iterator of FrameResponse, one per frame, in the frames' order.

        frames: any iterable (a list, a generator reading a camera). Each
            item is an image as for detect(), a (frame_id, image) pair, or a
            ready FrameRequest. Frame ids are first_frame_id, +1, ...
            unless given. It is read only as the window allows.
        config: create or confirm the session (CreateSession) before the
            first call and after every reconnection. Without it the session
            must exist; its resolved config is read once (GetSession) and used
            to re-create it when a restarted server has lost it.
        window: frames sent and not yet answered, at most.
        reconnect: when a call fails with a transient status (UNAVAILABLE:
            server restarted or draining; a broken connection; a stall; the
            session gone), wait (0.1 s doubling to 2 s, +-20 %), reconnect,
            and resend every frame not yet answered. Every frame is answered
            exactly once, in order. Tracking goes on across the reconnection:
            the new call carries the server's latest resume state, so lane
            ids continue on whichever replica answers.
        give_up_after, max_reconnects: the stream gives up with StreamError,
            whose .code and .details are the failed call's own status, when
            no frame has been answered for give_up_after seconds, or when the
            same status code comes back after max_reconnects reconnections
            in a row with no frame answered (None: no such limit; 0: at the
            first failure; the server's own "starting" and "draining" never
            count). The default, 10, is about 13 s of backoff: longer than a
            restart keeps the connection refused, and far shorter than
            give_up_after for a failure that repeats (a proxy refusing the
            call).
        stall_timeout: a call with frames in flight that gets no response
            for this long is cancelled and retried (None: never).

        camera_id must be 1 to 128 characters of [A-Za-z0-9._:/-], as the
        server wants: any other raises ValueError before anything is sent
        (every call that takes a camera id checks it).

        A frame the server cannot use is answered with its own status
        (e.g. response.status.code == FRAME_CODE_INVALID_ARGUMENT) and the
        stream goes on. Close the FrameStream (or leave its `with` block,
        or stop iterating it and drop it) to cancel the call.
        """
        return FrameStream(self, camera_id, frames, config=config, replace=replace,
                           window=window, first_frame_id=first_frame_id, rgb=rgb,
                           reconnect=reconnect, give_up_after=give_up_after,
                           stall_timeout=stall_timeout, max_reconnects=max_reconnects)

    # used by FrameStream
    def _stream_call(self, requests, camera_id):
        return self._stub.StreamFrames(requests,
                                       metadata=camera_metadata(self._metadata, camera_id))
