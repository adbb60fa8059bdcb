"""AsyncLaneClient and AsyncFrameStream: LaneClient and FrameStream over
asyncio (grpc.aio), with the same calls, arguments and guarantees.

    import asyncio
    from lane_client import AsyncLaneClient

    async def main():
        async with AsyncLaneClient("127.0.0.1:50051") as client:
            await client.create_session("cam0", "configs/synthetic.json")
            response = await client.detect("cam0", open("frame.jpg", "rb").read())
            async for response in client.stream("cam0", frames):  # list, iterator
                ...                                               # or async iterator

    asyncio.run(main())

Make the client inside the event loop that uses it (grpc.aio binds a channel
to its loop). The stream keeps lane-client's contract (streaming.py): at
most `window` frames in flight, each frame answered exactly once and in
order; on a transient failure it waits (0.1 s doubling to 2 s, +-20 %),
re-creates or confirms the session, reconnects and resends what was not
answered, and gives up (StreamError) as FrameStream does: the same status
code after max_reconnects reconnections in a row, or no frame answered for
give_up_after seconds. A source may be a plain iterable (read between writes: keep it
quick) or an async iterable (a camera read without blocking the loop).
"""

import asyncio
import collections
import contextlib
import logging
import time
from typing import Any, AsyncIterable, AsyncIterator, Iterable, List, Optional, Sequence, Tuple, Union

import grpc
import grpc.aio

from . import _stubs
from .client import (_CHANNEL_OPTIONS, Config, Image, bearer_metadata, camera_metadata,
                     channel_credentials, session_config)
from .camera_id import check_camera_id
from .errors import LaneError, SessionNotFoundError, from_rpc_error
from .frames import fill_image
from .streaming import (DEFAULT_MAX_RECONNECTS, TRANSIENT, _check_max_reconnects, _Pending,
                        _Reconnect, _Retry, _Tracking)

log = logging.getLogger("lane_client")

Frames = Union[Iterable[Any], AsyncIterable[Any]]


class AsyncLaneClient:
    """LaneClient's calls, awaited. Arguments as LaneClient's.

    Usable as an async context manager; `await close()` closes the channel.
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
            self._channel = grpc.aio.secure_channel(target, credentials, options=channel_options)
        else:
            self._channel = grpc.aio.insecure_channel(target, options=channel_options)
        self._stub = pb2_grpc.LaneServiceStub(self._channel)

    async def close(self) -> None:
        await self._channel.close()

    async def __aenter__(self) -> "AsyncLaneClient":
        return self

    async def __aexit__(self, *exc: Any) -> None:
        await self.close()

    @property
    def channel(self) -> grpc.aio.Channel:
        """The grpc.aio.Channel (for other services on the same port, e.g. health)."""
        return self._channel

    @property
    def metadata(self) -> Tuple[Tuple[str, str], ...]:
        return self._metadata

    async def _call(self, name: str, request: Any, timeout: Optional[float] = None,
                    camera_id: Optional[str] = None) -> Any:
        method = getattr(self._stub, name)
        if camera_id is not None:
            check_camera_id(camera_id)
        try:
            return await method(request, timeout=self.timeout if timeout is None else timeout,
                                metadata=camera_metadata(self._metadata, camera_id))
        except grpc.aio.AioRpcError as e:
            raise from_rpc_error(e, name) from e

    def session_config(self, config: Config) -> Any:
        return session_config(self.pb2, config)

    async def create_session(self, camera_id: str, config: Config, *, replace: bool = False,
                             timeout: Optional[float] = None) -> Any:
        """CreateSessionResponse (see LaneClient.create_session)."""
        request = self.pb2.CreateSessionRequest(camera_id=camera_id,
                                                config=self.session_config(config),
                                                replace=replace)
        return await self._call("CreateSession", request, timeout, camera_id)

    async def get_session(self, camera_id: str, *, timeout: Optional[float] = None) -> Any:
        return await self._call("GetSession", self.pb2.GetSessionRequest(camera_id=camera_id),
                                timeout, camera_id)

    async def list_sessions(self, *, timeout: Optional[float] = None) -> List[Any]:
        response = await self._call("ListSessions", self.pb2.ListSessionsRequest(), timeout)
        return list(response.sessions)

    async def delete_session(self, camera_id: str, *, timeout: Optional[float] = None) -> None:
        await self._call("DeleteSession", self.pb2.DeleteSessionRequest(camera_id=camera_id),
                         timeout, camera_id)

    async def server_info(self, *, timeout: Optional[float] = None) -> Any:
        return await self._call("GetServerInfo", self.pb2.GetServerInfoRequest(), timeout)

    def frame_request(self, camera_id: str, image: Image, *, frame_id: int = 0,
                      capture_time_unix_ns: int = 0, rgb: bool = False) -> Any:
        request = self.pb2.FrameRequest(camera_id=camera_id, frame_id=frame_id,
                                        capture_time_unix_ns=capture_time_unix_ns)
        return fill_image(request, image, self.pb2, rgb=rgb)

    async def detect(self, camera_id: str, image: Image, *, frame_id: int = 0,
                     capture_time_unix_ns: int = 0, rgb: bool = False,
                     config: Optional[Config] = None, replace: bool = False,
                     timeout: Optional[float] = None) -> Any:
        """FrameResponse of one frame (see LaneClient.detect)."""
        request = self.frame_request(camera_id, image, frame_id=frame_id,
                                     capture_time_unix_ns=capture_time_unix_ns, rgb=rgb)
        if config is not None:
            request.session_config.CopyFrom(self.session_config(config))
            request.replace_session = replace
        return await self._call("Detect", request, timeout, camera_id)

    def stream(self, camera_id: str, frames: Frames, *, config: Optional[Config] = None,
               replace: bool = False, window: int = 8, first_frame_id: int = 0,
               rgb: bool = False, reconnect: bool = True, give_up_after: float = 60.0,
               stall_timeout: Optional[float] = 30.0,
               max_reconnects: Optional[int] = DEFAULT_MAX_RECONNECTS) -> "AsyncFrameStream":
        """An AsyncFrameStream: `async for response in client.stream(...)`
        (arguments as LaneClient.stream)."""
        return AsyncFrameStream(self, camera_id, frames, config=config, replace=replace,
                                window=window, first_frame_id=first_frame_id, rgb=rgb,
                                reconnect=reconnect, give_up_after=give_up_after,
                                stall_timeout=stall_timeout, max_reconnects=max_reconnects)

    def _stream_call(self, camera_id: str) -> Any:
        return self._stub.StreamFrames(metadata=camera_metadata(self._metadata, camera_id))


class AsyncFrameStream:
    """Async iterator of FrameResponse, one per frame of the source, in order.

    Counters as FrameStream's: frames, connections, resent, failures; session.
    `await aclose()` (or leaving `async with`) cancels the call.
    """

    def __init__(self, client: AsyncLaneClient, camera_id: str, frames: Frames, *,
                 config: Optional[Config] = None, replace: bool = False, window: int = 8,
                 first_frame_id: int = 0, rgb: bool = False, reconnect: bool = True,
                 give_up_after: float = 60.0, stall_timeout: Optional[float] = 30.0,
                 max_reconnects: Optional[int] = DEFAULT_MAX_RECONNECTS) -> None:
        if window < 1:
            raise ValueError("window must be at least 1")
        check_camera_id(camera_id)
        self._max_reconnects = _check_max_reconnects(max_reconnects)
        self._client = client
        self._pb2 = client.pb2
        self.camera_id = camera_id
        if hasattr(frames, "__aiter__"):
            self._source: Any = frames.__aiter__()  # type: ignore[union-attr]
            self._async_source = True
        else:
            self._source = iter(frames)  # type: ignore[arg-type]
            self._async_source = False
        self._config = client.session_config(config) if config is not None else None
        self._replace = replace
        self._window = int(window)
        self._next_frame_id = int(first_frame_id)
        self._rgb = rgb
        self._reconnect = reconnect
        self._give_up_after = give_up_after
        self._stall_timeout = stall_timeout

        self._pending: "collections.deque[_Pending]" = collections.deque()
        self._sent = 0                 # of _pending, written on the current call
        self._room = asyncio.Event()   # set when a response frees the window
        self._source_done = False
        self._source_error: Optional[BaseException] = None
        self._stalled = False
        self._progress = False

        self.frames = 0
        self.connections = 0
        self.resent = 0
        self.failures: List[str] = []
        self.tracking = _Tracking(camera_id)
        self.session: Any = None
        self._gen: Optional[AsyncIterator[Any]] = None

    def __aiter__(self) -> AsyncIterator[Any]:
        if self._gen is None:
            self._gen = self._run()
        return self._gen

    async def aclose(self) -> None:
        """Cancels the call; frames not yet answered stay unanswered."""
        if self._gen is not None:
            await self._gen.aclose()  # type: ignore[attr-defined]

    async def __aenter__(self) -> "AsyncFrameStream":
        return self

    async def __aexit__(self, *exc: Any) -> None:
        await self.aclose()

    # -- the source ---------------------------------------------------------

    def _make_request(self, item: Any) -> Tuple[int, Any]:
        pb2 = self._pb2
        if isinstance(item, pb2.FrameRequest):
            if not item.camera_id:
                item.camera_id = self.camera_id
            return item.frame_id, item
        if isinstance(item, tuple) and len(item) == 2:
            frame_id, image = int(item[0]), item[1]
        else:
            frame_id, image = self._next_frame_id, item
        self._next_frame_id = frame_id + 1
        return frame_id, self._client.frame_request(self.camera_id, image, frame_id=frame_id,
                                                    rgb=self._rgb)

    async def _pull(self) -> None:
        """Takes one frame from the source into the window (or marks it done)."""
        try:
            if self._async_source:
                item = await self._source.__anext__()
            else:
                item = next(self._source)
            self._pending.append(_Pending(*self._make_request(item)))
        except (StopIteration, StopAsyncIteration):
            self._source_done = True
        except Exception as e:  # the caller's source or frame is broken
            self._source_done = True
            self._source_error = e

    async def _write(self, call: Any) -> None:
        """The requests of one call: the pending frames not yet written on it,
        then new frames while the window has room; half-closes at the end."""
        first = True
        while True:
            while self._sent < len(self._pending):
                item = self._pending[self._sent]
                self._sent += 1
                item.attempts += 1
                if item.attempts > 1:
                    self.resent += 1
                item.sent_at = time.monotonic()
                await call.write(self.tracking.first_request(item.request) if first
                                 else item.request)
                first = False
            if self._source_done:
                await call.done_writing()
                return
            if len(self._pending) >= self._window:
                self._room.clear()
                await self._room.wait()
                continue
            await self._pull()

    # -- responses ----------------------------------------------------------

    async def _prepare_session(self, first: bool) -> None:
        client = self._client
        try:
            if self._config is None:
                self.session = await client.get_session(self.camera_id)
                self._config = self.session.config
                return
            response = await client.create_session(self.camera_id, self._config,
                                                   replace=self._replace and first)
        except LaneError as e:
            if e.code == grpc.StatusCode.NOT_FOUND:
                raise SessionNotFoundError(
                    f"no session for camera '{self.camera_id}' on {client.target}: create it "
                    "with create_session(), or pass config= to stream()",
                    e.code, e.details) from e
            if e.code in TRANSIENT:
                raise _Retry(e.code, str(e), e.details) from e
            raise
        if not first and response.outcome != self._pb2.CREATE_OUTCOME_UNCHANGED:
            log.warning("lane_client: session of camera '%s' re-created (version %d)",
                        self.camera_id, response.session.version)
        self.session = response.session

    def _take(self, response: Any) -> None:
        if self._sent == 0 or not self._pending:
            raise LaneError(f"StreamFrames: a response for frame_id {response.frame_id} "
                            "but no frame is in flight")
        oldest = self._pending[0]
        if response.frame_id != oldest.frame_id:
            raise LaneError(f"StreamFrames: a response for frame_id {response.frame_id} "
                            f"but the oldest unanswered frame is {oldest.frame_id}")
        self._pending.popleft()
        self._sent -= 1
        self._room.set()

    async def _attempt_call(self) -> AsyncIterator[Any]:
        """One StreamFrames call; yields its responses. Raises _Retry when it
        fails in a way that may be retried, returns when it ended with OK."""
        self._sent = 0
        self._stalled = False
        self.connections += 1
        call = self._client._stream_call(self.camera_id)
        writer = asyncio.ensure_future(self._write(call))
        read: Optional["asyncio.Future[Any]"] = None
        limit = self._stall_timeout
        waiting_since = time.monotonic()
        try:
            while True:
                if read is None:
                    read = asyncio.ensure_future(call.read())
                    waiting_since = time.monotonic()
                done, _ = await asyncio.wait({read}, timeout=min(1.0, limit / 4) if limit else None)
                if not done:
                    if self._sent > 0 and self._pending:
                        since = max(waiting_since, self._pending[0].sent_at)
                        if time.monotonic() - since > limit:  # type: ignore[operator]
                            self._stalled = True
                            call.cancel()
                    continue
                response, read = read.result(), None
                if response is grpc.aio.EOF:
                    return
                self._take(response)
                self.tracking.remember(response)
                self.frames += 1
                self._progress = True
                yield response
        except (grpc.aio.AioRpcError, asyncio.CancelledError) as e:
            if self._stalled:
                raise _Retry(grpc.StatusCode.CANCELLED,
                             f"stalled: no response for {limit:g} s with frames in flight") from e
            if isinstance(e, asyncio.CancelledError):
                raise
            code = e.code()
            if code in TRANSIENT:
                details = e.details() or ""
                raise _Retry(code, f"{code.name}: {details}".rstrip(": "), details) from e
            raise from_rpc_error(e, "StreamFrames") from e
        finally:
            call.cancel()  # no-op when the call is over
            writer.cancel()
            with contextlib.suppress(BaseException):
                await writer
            if read is not None:
                read.cancel()
                with contextlib.suppress(BaseException):
                    await read

    async def _run(self) -> AsyncIterator[Any]:
        first = True
        policy = _Reconnect(self.camera_id, self._reconnect, self._give_up_after, self.failures,
                            self._max_reconnects)
        while not (self._source_done and not self._pending):
            self._progress = False
            try:
                await self._prepare_session(first)
                first = False
                # Closed here, not left to the garbage collector, so that the
                # call is cancelled as soon as the caller stops iterating.
                attempt = self._attempt_call()
                try:
                    async for response in attempt:
                        yield response
                finally:
                    await attempt.aclose()  # type: ignore[attr-defined]
                if self._source_done and not self._pending:
                    break
                raise _Retry(grpc.StatusCode.UNKNOWN, f"the call ended with OK and "
                             f"{len(self._pending)} frames unanswered",
                             "the call ended with OK and frames unanswered")
            except _Retry as retry:
                failure = retry
            await asyncio.sleep(policy.after(failure, self._progress, len(self._pending)))
        if self._source_error is not None:
            raise self._source_error
