"""FrameStream: StreamFrames with a bounded window and reconnection.

How it works (the same contract as lane-client's Streamer, client/streamer.h):

  * `pending` holds the frames taken from the source and not yet answered, in
    order, at most `window` of them. The first `sent` of them have been
    written on the current call.
  * gRPC reads the call's requests from a generator (_requests) on a thread
    of its own. The generator writes the pending frames not yet written on
    this call, then takes new frames from the source while the window has
    room, and waits otherwise. When the source is exhausted and every pending
    frame is written, it returns: the call is half-closed and the server ends
    it with OK once every frame is answered.
  * The caller's thread reads the responses; each must answer the oldest
    pending frame (its frame_id is checked), which then leaves `pending`.
  * A call that fails with a transient status is followed, after a backoff,
    by a new call (and a CreateSession that re-creates or confirms the
    session), on which every pending frame is written again. A response is
    never asked for again once received, so each frame is answered exactly
    once; frames are taken from the source once.
  * Within two budgets (_Reconnect): the stream gives up with StreamError,
    carrying the failure's own status code and message, when the same
    status code comes back after `max_reconnects` reconnections in a row
    with no frame answered, or when no frame has been answered for
    `give_up_after` seconds.
  * Tracking survives the reconnection (docs/deployment.md): the stream
    keeps the latest resume state the server sent and the largest lane id
    it has seen (_Tracking), and the first request of every later call
    carries both, so that whichever replica takes the camera goes on with
    the same lane ids. Every call names its camera in the `x-camera-id`
    header, which a proxy hashes to keep a camera on one replica.
"""

import collections
import logging
import random
import threading
import time

import grpc

from .camera_id import check_camera_id
from .errors import LaneError, SessionNotFoundError, StreamError, from_rpc_error

log = logging.getLogger("lane_client")

# Statuses after which the stream reconnects and resends (as lane-client).
TRANSIENT = frozenset({
    grpc.StatusCode.UNAVAILABLE,          # server down, starting, draining, restarted
    grpc.StatusCode.DEADLINE_EXCEEDED,    # a unary call (CreateSession) timed out
    grpc.StatusCode.CANCELLED,            # the server went away, or a stall (our cancel)
    grpc.StatusCode.ABORTED,
    grpc.StatusCode.INTERNAL,             # a broken HTTP/2 stream
    grpc.StatusCode.UNKNOWN,
    grpc.StatusCode.RESOURCE_EXHAUSTED,   # full worker queue or session table
    grpc.StatusCode.FAILED_PRECONDITION,  # the session is gone: it is re-created
})

BACKOFF_INITIAL = 0.1
BACKOFF_MAX = 2.0
BACKOFF_JITTER = 0.2

# Reconnections in a row after failures with the same status code, by default
# (as lane-client's --max-reconnects): 11 attempts over about 13 s of backoff
# (0.1 + 0.2 + 0.4 + 0.8 + 1.6 + 5 x 2 s). That outlasts a restart: the
# server's own "the server is draining" and "the server is starting" never
# count (it is there, changing state), and the connection is refused only
# until the new process listens. A code that comes back 11 times with no
# frame answered is a failure that repeats (a proxy refusing every call, a
# server that stays away) and ends the stream in ~13 s instead of
# give_up_after's 60. The code, not the message, is compared: gRPC words one
# transport failure in many ways.
DEFAULT_MAX_RECONNECTS = 10

# The beginnings of lane-server's UNAVAILABLE messages while it starts or
# drains (wire/status_map.cc).
_SERVER_CHANGING_STATE = ("the server is starting", "the server is draining")


def _server_changing_state(code, details):
    return code == grpc.StatusCode.UNAVAILABLE and details.startswith(_SERVER_CHANGING_STATE)


class _Pending:
    __slots__ = ("frame_id", "request", "attempts", "sent_at")

    def __init__(self, frame_id, request):
        self.frame_id = frame_id
        self.request = request
        self.attempts = 0      # times written on a call
        self.sent_at = 0.0     # time.monotonic() of the last write


class _Reconnect:
    """What a stream does after a failed call or session step, the same for
    FrameStream and aio.AsyncFrameStream: record why; give up (StreamError,
    with the failure's code and message) when reconnection is off, when the
    same status code comes back after max_reconnects reconnections in a row
    with no frame answered (None: no limit; the server's own "starting" and
    "draining" never count), or when no frame was answered for
    give_up_after seconds; else wait 0.1 s doubling to 2 s (+-20 %). A call
    that answered frames starts both the wait and the budgets again."""

    def __init__(self, camera_id, reconnect, give_up_after, failures,
                 max_reconnects=DEFAULT_MAX_RECONNECTS):
        self._camera_id = camera_id
        self._reconnect = reconnect
        self._give_up_after = give_up_after
        self._max_reconnects = max_reconnects
        self._failures = failures  # the stream's public list, appended to
        self._backoff = BACKOFF_INITIAL
        self._last_progress = time.monotonic()
        self._code = None          # of the failures in a row
        self._first = ""           # the first of them, as reported
        self.repeats = 0           # failures in a row with that code, since progress

    def after(self, failure, progressed, unanswered):
        """Seconds to wait before the next call; raises StreamError to give up."""
        if progressed:
            self._backoff = BACKOFF_INITIAL
            self._last_progress = time.monotonic()
            self._code, self._first, self.repeats = None, "", 0
        self._failures.append(failure.text)
        if _server_changing_state(failure.code, failure.details):
            self._code, self._first, self.repeats = None, "", 0
        elif self.repeats and failure.code == self._code:
            self.repeats += 1
        else:
            self._code, self._first, self.repeats = failure.code, failure.text, 1

        def give_up(message):
            return StreamError(message, failure.code, failure.details, failures=self._failures)

        if not self._reconnect:
            raise give_up(f"StreamFrames: {failure.text}")
        limit = self._max_reconnects
        if limit is not None and self.repeats > limit:
            if limit == 0:
                raise give_up(f"StreamFrames: {failure.text}; gave up at the first failure "
                              "(max_reconnects=0)")
            first = "" if self._first == failure.text else f"; the first of them: {self._first}"
            raise give_up(f"StreamFrames: {failure.text}; {failure.code.name} on {self.repeats} "
                          "attempts in a row with no frame answered: gave up (at most "
                          f"max_reconnects={limit} reconnections after the same failure){first}")
        if time.monotonic() - self._last_progress > self._give_up_after:
            raise give_up(f"StreamFrames: no frame answered for {self._give_up_after:g} s; "
                          f"last error: {failure.text}")
        wait = self._backoff * random.uniform(1 - BACKOFF_JITTER, 1 + BACKOFF_JITTER)
        self._backoff = min(self._backoff * 2, BACKOFF_MAX)
        log.warning("lane_client: camera '%s': %s; reconnecting in %.0f ms "
                    "(%d frames to resend)", self._camera_id, failure.text, wait * 1000,
                    unanswered)
        return wait


def _check_max_reconnects(max_reconnects):
    """max_reconnects as given: None or an int >= 0 (ValueError otherwise)."""
    if max_reconnects is None:
        return None
    if isinstance(max_reconnects, bool) or not isinstance(max_reconnects, int) \
            or max_reconnects < 0:
        raise ValueError(f"max_reconnects must be None or an int >= 0, not {max_reconnects!r}")
    return max_reconnects


class _Tracking:
    """What a stream keeps for its next call, the same for FrameStream and
    aio.AsyncFrameStream: the latest resume state and the largest lane id.

    Counters: resumes (calls opened with them), resumes_refused (the server
    refused the state and started tracking afresh, with ids above the
    largest seen), resume_states and resume_state_bytes (received)."""

    def __init__(self, camera_id):
        self._camera_id = camera_id
        self.state = b""
        self.max_lane_id = 0
        self.resumes = 0
        self.resumes_refused = 0
        self.resume_states = 0
        self.resume_state_bytes = 0

    def remember(self, response):
        if response.HasField("resume_status") and response.resume_status.code != 0:
            self.resumes_refused += 1
            log.warning("lane_client: camera '%s': the server did not resume tracking (%s); "
                        "lane ids go on from the largest seen", self._camera_id,
                        response.resume_status.message)
        if response.resume_state:
            self.state = response.resume_state
            self.resume_states += 1
            self.resume_state_bytes += len(response.resume_state)
        for lane in response.lanes:
            if lane.id > self.max_lane_id:
                self.max_lane_id = lane.id

    def first_request(self, request):
        """The first request of a call: a copy with the resume state and the
        lowest new lane id, or `request` itself before anything was seen."""
        if not self.state and not self.max_lane_id:
            return request
        resumed = type(request)()
        resumed.CopyFrom(request)
        resumed.resume_state = self.state
        resumed.min_lane_id = self.max_lane_id + 1
        self.resumes += 1
        return resumed


class _Retry(Exception):
    """A call or session step failed in a way that may be retried: its
    status code, its message (`details`, as the server or gRPC said it) and
    how it is reported (`text`)."""

    def __init__(self, code, text, details=None):
        super().__init__(text)
        self.code = code
        self.text = text
        self.details = text if details is None else details


class FrameStream:
    """Iterator of FrameResponse, one per frame of the source, in order.

    Counters, readable while and after iterating:
      frames       responses handed out
      connections  StreamFrames calls opened
      resent       writes of a frame after its first
      failures     why each failed call or session step was retried (strings)
      tracking     resume counters across reconnections (resumes,
                   resumes_refused, resume_states, resume_state_bytes)
    """

    def __init__(self, client, camera_id, frames, *, config=None, replace=False, window=8,
                 first_frame_id=0, rgb=False, reconnect=True, give_up_after=60.0,
                 stall_timeout=30.0, max_reconnects=DEFAULT_MAX_RECONNECTS):
        if window < 1:
            raise ValueError("window must be at least 1")
        check_camera_id(camera_id)
        self._max_reconnects = _check_max_reconnects(max_reconnects)
        self._client = client
        self._pb2 = client.pb2
        self.camera_id = camera_id
        self._source = iter(frames)
        self._config = client.session_config(config) if config is not None else None
        self._replace = replace
        self._window = int(window)
        self._next_frame_id = int(first_frame_id)
        self._rgb = rgb
        self._reconnect = reconnect
        self._give_up_after = give_up_after
        self._stall_timeout = stall_timeout

        self._cond = threading.Condition()
        self._pending = collections.deque()
        self._sent = 0
        self._pulling = False
        self._source_done = False
        self._source_error = None
        self._attempt = 0
        self._attempt_over = True
        self._waiting_since = None   # set while the caller waits for a response
        self._stalled = False

        self.frames = 0
        self.connections = 0
        self.resent = 0
        self.failures = []
        self.tracking = _Tracking(camera_id)
        self.session = None          # the Session of the last CreateSession/GetSession
        self._gen = self._run()

    # -- iterator protocol --------------------------------------------------

    def __iter__(self):
        return self

    def __next__(self):
        return next(self._gen)

    def close(self):
        """Cancels the call; frames not yet answered stay unanswered."""
        self._gen.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    # -- the source, on gRPC's request thread ---------------------------------

    def _make_request(self, item):
        pb2 = self._pb2
        if isinstance(item, pb2.FrameRequest):
            request = item
            if not request.camera_id:
                request.camera_id = self.camera_id
            return request.frame_id, request
        if isinstance(item, tuple) and len(item) == 2:
            frame_id, image = item
            frame_id = int(frame_id)
        else:
            frame_id, image = self._next_frame_id, item
        self._next_frame_id = frame_id + 1
        request = self._client.frame_request(self.camera_id, image, frame_id=frame_id,
                                             rgb=self._rgb)
        return frame_id, request

    def _requests(self, attempt):
        """The requests of call `attempt` (run by gRPC on its own thread)."""
        cond = self._cond
        first = True
        while True:
            pull = False
            with cond:
                while True:
                    if attempt != self._attempt or self._attempt_over:
                        return
                    if self._sent < len(self._pending):
                        item = self._pending[self._sent]
                        self._sent += 1
                        item.attempts += 1
                        if item.attempts > 1:
                            self.resent += 1
                        item.sent_at = time.monotonic()
                        break
                    if self._source_done:
                        return  # everything written: half-close
                    if len(self._pending) < self._window and not self._pulling:
                        self._pulling = True
                        pull = True
                        break
                    cond.wait()
            if not pull:
                if first:
                    first = False
                    with cond:
                        request = self.tracking.first_request(item.request)
                    yield request
                else:
                    yield item.request
                continue
            # Read the source outside the lock: a camera may take its time.
            entry, done, error = None, False, None
            try:
                entry = self._make_request(next(self._source))
            except StopIteration:
                done = True
            except Exception as e:  # the caller's source or frame is broken
                done, error = True, e
            with cond:
                self._pulling = False
                if entry is not None:
                    self._pending.append(_Pending(*entry))
                if done:
                    self._source_done = True
                    self._source_error = error
                cond.notify_all()

    # -- the caller's thread ------------------------------------------------

    def _prepare_session(self, first):
        """Creates or confirms the session before a call (raises _Retry or LaneError)."""
        client = self._client
        try:
            if self._config is None:
                # The session must exist; its resolved config re-creates it later.
                self.session = client.get_session(self.camera_id)
                self._config = self.session.config
                return
            response = client.create_session(self.camera_id, self._config,
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

    def _watch(self, attempt, call):
        """Cancels call `attempt` when frames are in flight and nothing comes back."""
        limit = self._stall_timeout
        with self._cond:
            while attempt == self._attempt and not self._attempt_over:
                now = time.monotonic()
                if self._waiting_since is not None and self._sent > 0:
                    since = max(self._waiting_since, self._pending[0].sent_at)
                    if now - since > limit:
                        self._stalled = True
                        call.cancel()
                        return
                self._cond.wait(timeout=min(1.0, limit / 4))

    def _take(self, response):
        """Matches a response to the oldest pending frame; the frame leaves the window."""
        with self._cond:
            if self._sent == 0 or not self._pending:
                raise LaneError(f"StreamFrames: a response for frame_id {response.frame_id} "
                                "but no frame is in flight")
            oldest = self._pending[0]
            if response.frame_id != oldest.frame_id:
                raise LaneError(f"StreamFrames: a response for frame_id {response.frame_id} "
                                f"but the oldest unanswered frame is {oldest.frame_id}")
            self._pending.popleft()
            self._sent -= 1
            self._cond.notify_all()

    def _attempt_call(self):
        """One StreamFrames call; yields its responses. Raises _Retry when it
        fails in a way that may be retried, returns when it ended with OK."""
        cond = self._cond
        with cond:
            self._attempt += 1
            attempt = self._attempt
            self._sent = 0
            self._attempt_over = False
            self._stalled = False
            cond.notify_all()
        self.connections += 1
        call = self._client._stream_call(self._requests(attempt), self.camera_id)
        watchdog = None
        if self._stall_timeout:
            watchdog = threading.Thread(target=self._watch, args=(attempt, call),
                                        name="lane_client-stall", daemon=True)
            watchdog.start()
        try:
            responses = iter(call)
            while True:
                with cond:
                    self._waiting_since = time.monotonic()
                try:
                    response = next(responses)
                except StopIteration:
                    return
                finally:
                    with cond:
                        self._waiting_since = None
                self._take(response)
                with cond:
                    self.tracking.remember(response)
                self.frames += 1
                self._progress = True
                yield response
        except grpc.RpcError as e:
            code = e.code()
            if self._stalled:
                text = (f"stalled: no response for {self._stall_timeout:g} s "
                        "with frames in flight")
                details = text
            else:
                details = e.details() or ""
                text = f"{code.name}: {details}".rstrip(": ")
            if code in TRANSIENT:
                raise _Retry(code, text, details) from e
            raise from_rpc_error(e, "StreamFrames") from e
        finally:
            with cond:
                self._attempt_over = True
                cond.notify_all()
            call.cancel()  # no-op when the call is over

    def _run(self):
        first = True
        policy = _Reconnect(self.camera_id, self._reconnect, self._give_up_after, self.failures,
                            self._max_reconnects)
        while True:
            with self._cond:
                if self._source_done and not self._pending:
                    break
            self._progress = False
            try:
                self._prepare_session(first)
                first = False
                yield from self._attempt_call()
                with self._cond:
                    if self._source_done and not self._pending:
                        break
                    unanswered = len(self._pending)
                raise _Retry(grpc.StatusCode.UNKNOWN,
                             f"the call ended with OK and {unanswered} frames unanswered",
                             "the call ended with OK and frames unanswered")
            except _Retry as retry:
                failure = retry
            with self._cond:
                unanswered = len(self._pending)
            time.sleep(policy.after(failure, self._progress, unanswered))
        if self._source_error is not None:
            raise self._source_error
