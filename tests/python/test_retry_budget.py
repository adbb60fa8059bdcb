#!/usr/bin/env python3
"""The Python client's retry budget (issue 47), against a fake server.

A failure that repeats call after call must end the stream with its own
status (StreamError with .code and .details), not an endless retry loop;
a camera id the server would refuse is a ValueError before anything is sent.

The server is a grpc.server with a generic handler for lane.v1.LaneService:
its session calls answer (or fail with a chosen status) and its StreamFrames
ends every call at once with UNAVAILABLE, as a proxy refusing the call does
(nginx's GOAWAY ENHANCE_YOUR_CALM reaches a gRPC client as UNAVAILABLE).

Run by ctest as `python_client_retry` (tests/python/CMakeLists.txt), which
sets LANE_CLIENT_STUBS (the stubs the build generated; generated here with
lane_client.generate when missing) and LANE_SOURCE_DIR. No lane-server is
needed. Exits 77 (ctest: skipped) when python3-grpcio or python3-protobuf
is missing. stdlib unittest only.
"""

import asyncio
import os
import shutil
import subprocess
import sys
import tempfile
import threading
import time
import unittest
from concurrent import futures
from unittest import mock

SKIP_EXIT = 77
try:
    import grpc
    import google.protobuf  # noqa: F401  (python3-protobuf)
except ImportError as e:
    print(f"skipped: {e}: the Python client needs Debian's python3-grpcio and "
          "python3-protobuf (scripts/install-deps.sh installs them)")
    sys.exit(SKIP_EXIT)

SOURCE_DIR = os.environ.get("LANE_SOURCE_DIR") or os.path.abspath(
    os.path.join(os.path.dirname(__file__), "..", ".."))
PACKAGE_DIR = os.path.join(SOURCE_DIR, "client", "python")
sys.path.insert(0, PACKAGE_DIR)

CLOSED = "closed by the test server"
TMP = None
lane_client = None
pb2 = None


def setUpModule():
    global TMP, lane_client, pb2
    TMP = tempfile.mkdtemp(prefix="lane_retry_test_")
    stubs = os.environ.get("LANE_CLIENT_STUBS", "")
    if not stubs or not os.path.isfile(os.path.join(stubs, "lane", "v1", "lane_service_pb2.py")):
        stubs = os.path.join(TMP, "stubs")
        subprocess.run([sys.executable, "-m", "lane_client.generate", "--quiet", "--out", stubs],
                       cwd=PACKAGE_DIR, check=True)
        os.environ["LANE_CLIENT_STUBS"] = stubs
    import lane_client as module
    lane_client = module
    pb2 = lane_client.load_stubs()[0]


def tearDownModule():
    if TMP:
        shutil.rmtree(TMP, ignore_errors=True)


class ClosingServer:
    """lane.v1.LaneService on a free loopback port: session calls answer
    (or end with session_status), StreamFrames ends at once with
    stream_status (its message followed by " (call N)" with number_calls: a
    failure worded anew every time, as gRPC's transport failures are);
    `calls` counts the calls by method."""

    def __init__(self, stream_status=(grpc.StatusCode.UNAVAILABLE, CLOSED), session_status=None,
                 number_calls=False):
        self.calls = {"CreateSession": 0, "GetSession": 0, "StreamFrames": 0}
        self._number_calls = number_calls
        self._lock = threading.Lock()
        self._stream_status = stream_status
        self._session_status = session_status
        handlers = {
            "CreateSession": grpc.unary_unary_rpc_method_handler(
                self._create, request_deserializer=pb2.CreateSessionRequest.FromString,
                response_serializer=pb2.CreateSessionResponse.SerializeToString),
            "GetSession": grpc.unary_unary_rpc_method_handler(
                self._get, request_deserializer=pb2.GetSessionRequest.FromString,
                response_serializer=pb2.Session.SerializeToString),
            "StreamFrames": grpc.stream_stream_rpc_method_handler(
                self._stream, request_deserializer=pb2.FrameRequest.FromString,
                response_serializer=pb2.FrameResponse.SerializeToString),
        }
        self.server = grpc.server(futures.ThreadPoolExecutor(max_workers=4))
        self.server.add_generic_rpc_handlers(
            (grpc.method_handlers_generic_handler("lane.v1.LaneService", handlers),))
        self.port = self.server.add_insecure_port("127.0.0.1:0")
        self.server.start()

    @property
    def target(self):
        return f"127.0.0.1:{self.port}"

    def stop(self):
        self.server.stop(None)

    def _count(self, method):
        with self._lock:
            self.calls[method] += 1
            return self.calls[method]

    def _fail(self, context, status):
        context.set_code(status[0])
        context.set_details(status[1])

    def _create(self, request, context):
        self._count("CreateSession")
        if self._session_status:
            self._fail(context, self._session_status)
            return pb2.CreateSessionResponse()
        return pb2.CreateSessionResponse(
            outcome=pb2.CREATE_OUTCOME_UNCHANGED,
            session=pb2.Session(camera_id=request.camera_id, config=request.config))

    def _get(self, request, context):
        self._count("GetSession")
        if self._session_status:
            self._fail(context, self._session_status)
            return pb2.Session()
        return pb2.Session(camera_id=request.camera_id)

    def _stream(self, requests, context):
        call = self._count("StreamFrames")
        code, message = self._stream_status
        self._fail(context, (code, f"{message} (call {call})" if self._number_calls else message))
        return iter(())


FRAMES = [b"\xff\xd8 not looked at"] * 4
CONFIG = {"camera": {}}


class SyncBudgetTest(unittest.TestCase):

    def setUp(self):
        self.server = ClosingServer()
        self.client = lane_client.LaneClient(self.server.target, token="")

    def tearDown(self):
        self.client.close()
        self.server.stop()

    def test_gives_up_on_a_repeated_status(self):
        started = time.monotonic()
        with self.assertRaises(lane_client.StreamError) as caught:
            list(self.client.stream("cam", FRAMES, config=CONFIG, max_reconnects=3))
        elapsed = time.monotonic() - started
        print(f"\n[figures] FrameStream max_reconnects=3: gave up after {elapsed:.3f} s",
              file=sys.stderr)
        error = caught.exception
        self.assertEqual(error.code, grpc.StatusCode.UNAVAILABLE)
        self.assertEqual(error.details, CLOSED)
        self.assertIn(f"UNAVAILABLE: {CLOSED}", str(error))
        self.assertIn("4 attempts in a row", str(error))
        self.assertEqual(len(error.failures), 4)
        self.assertEqual(self.server.calls["StreamFrames"], 4)
        # Backoff 0.1 + 0.2 + 0.4 s (+-20 %), far from give_up_after's 60 s.
        self.assertLess(elapsed, 10)

    def test_the_default_is_ten_reconnections(self):
        # The schedule shortened: the count is what is tested.
        with mock.patch.object(lane_client.streaming, "BACKOFF_INITIAL", 0.001), \
                mock.patch.object(lane_client.streaming, "BACKOFF_MAX", 0.005):
            with self.assertRaises(lane_client.StreamError) as caught:
                list(self.client.stream("cam", FRAMES, config=CONFIG))
        self.assertEqual(self.server.calls["StreamFrames"], 11)
        self.assertIn("11 attempts in a row", str(caught.exception))
        self.assertIn("max_reconnects=10", str(caught.exception))

    def test_zero_gives_up_at_the_first_failure(self):
        with self.assertRaises(lane_client.StreamError) as caught:
            list(self.client.stream("cam", FRAMES, config=CONFIG, max_reconnects=0))
        self.assertEqual(caught.exception.code, grpc.StatusCode.UNAVAILABLE)
        self.assertEqual(self.server.calls["StreamFrames"], 1)

    def test_time_budget_keeps_the_failures_code(self):
        started = time.monotonic()
        with self.assertRaises(lane_client.StreamError) as caught:
            list(self.client.stream("cam", FRAMES, config=CONFIG, max_reconnects=None,
                                    give_up_after=1.0))
        elapsed = time.monotonic() - started
        self.assertEqual(caught.exception.code, grpc.StatusCode.UNAVAILABLE)
        self.assertEqual(caught.exception.details, CLOSED)
        self.assertIn("no frame answered for 1 s", str(caught.exception))
        self.assertGreaterEqual(elapsed, 1.0)
        self.assertLess(elapsed, 10)

    def test_bad_arguments_are_value_errors(self):
        for camera_id in ("c" * 65536, "front left", "", "cam\n1", "caméra"):
            with self.assertRaises(ValueError, msg=repr(camera_id[:20])) as caught:
                self.client.stream(camera_id, FRAMES, config=CONFIG)
            self.assertLess(len(str(caught.exception)), 200)
            with self.assertRaises(ValueError):
                self.client.create_session(camera_id, CONFIG)
            with self.assertRaises(ValueError):
                self.client.get_session(camera_id)
            with self.assertRaises(ValueError):
                self.client.detect(camera_id, FRAMES[0])
        self.assertEqual(self.client.stream("a" * 128, [], config=CONFIG).camera_id, "a" * 128)
        with self.assertRaises(ValueError):
            self.client.stream("cam", FRAMES, max_reconnects=-1)
        self.assertEqual(sum(self.server.calls.values()), 0)

    def test_command_line_refuses_a_bad_camera_id(self):
        env = dict(os.environ, PYTHONPATH=PACKAGE_DIR)
        done = subprocess.run([sys.executable, "-m", "lane_client", "--target",
                               self.server.target, "session", "get", "x" * 200],
                              env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                              universal_newlines=True, timeout=60)
        self.assertEqual(done.returncode, 2, done.stderr)
        self.assertIn("1 to 128 characters, got 200", done.stderr)
        self.assertEqual(sum(self.server.calls.values()), 0)


class WordingTest(unittest.TestCase):
    """The code counts, not the wording; the server's own 'draining' never counts."""

    def test_a_code_that_repeats_in_other_words(self):
        server = ClosingServer(number_calls=True)
        try:
            with lane_client.LaneClient(server.target, token="") as client:
                with self.assertRaises(lane_client.StreamError) as caught:
                    list(client.stream("cam", FRAMES, config=CONFIG, max_reconnects=3))
        finally:
            server.stop()
        message = str(caught.exception)
        self.assertEqual(caught.exception.code, grpc.StatusCode.UNAVAILABLE)
        self.assertEqual(caught.exception.details, f"{CLOSED} (call 4)")
        self.assertIn("UNAVAILABLE on 4 attempts in a row", message)
        self.assertIn(f"the first of them: UNAVAILABLE: {CLOSED} (call 1)", message)
        self.assertEqual(server.calls["StreamFrames"], 4)

    def test_a_draining_server_is_waited_out(self):
        server = ClosingServer(stream_status=(grpc.StatusCode.UNAVAILABLE,
                                              "the server is draining (shutting down)"))
        try:
            with lane_client.LaneClient(server.target, token="") as client:
                with self.assertRaises(lane_client.StreamError) as caught:
                    list(client.stream("cam", FRAMES, config=CONFIG, max_reconnects=1,
                                       give_up_after=1.0))
        finally:
            server.stop()
        # Ended by the time budget, after more calls than max_reconnects=1
        # would have allowed had they counted (it allows 2).
        self.assertIn("no frame answered for 1 s", str(caught.exception))
        self.assertGreaterEqual(server.calls["StreamFrames"], 2)


class SessionStepTest(unittest.TestCase):
    """Every call fails, the session step first: the stream ends with its code."""

    def test_session_step_failure_keeps_its_code(self):
        server = ClosingServer(session_status=(grpc.StatusCode.RESOURCE_EXHAUSTED,
                                               "too many sessions"))
        try:
            with lane_client.LaneClient(server.target, token="") as client:
                with self.assertRaises(lane_client.StreamError) as caught:
                    list(client.stream("cam", FRAMES, config=CONFIG, max_reconnects=2))
        finally:
            server.stop()
        self.assertEqual(caught.exception.code, grpc.StatusCode.RESOURCE_EXHAUSTED)
        self.assertEqual(caught.exception.details, "too many sessions")
        self.assertIn("3 attempts in a row", str(caught.exception))
        self.assertEqual(server.calls["CreateSession"], 3)
        self.assertEqual(server.calls["StreamFrames"], 0)


class AsyncBudgetTest(unittest.TestCase):

    def setUp(self):
        self.server = ClosingServer()

    def tearDown(self):
        self.server.stop()

    def test_gives_up_on_a_repeated_status(self):
        async def main():
            async with lane_client.AsyncLaneClient(self.server.target, token="") as client:
                stream = client.stream("cam", FRAMES, config=CONFIG, max_reconnects=3)
                return [r async for r in stream]

        started = time.monotonic()
        with self.assertRaises(lane_client.StreamError) as caught:
            asyncio.run(main())
        elapsed = time.monotonic() - started
        print(f"\n[figures] AsyncFrameStream max_reconnects=3: gave up after {elapsed:.3f} s",
              file=sys.stderr)
        self.assertEqual(caught.exception.code, grpc.StatusCode.UNAVAILABLE)
        self.assertEqual(caught.exception.details, CLOSED)
        self.assertIn("4 attempts in a row", str(caught.exception))
        self.assertEqual(self.server.calls["StreamFrames"], 4)
        self.assertLess(elapsed, 10)

    def test_time_budget(self):
        async def main():
            async with lane_client.AsyncLaneClient(self.server.target, token="") as client:
                stream = client.stream("cam", FRAMES, config=CONFIG, max_reconnects=None,
                                       give_up_after=1.0)
                return [r async for r in stream]

        with self.assertRaises(lane_client.StreamError) as caught:
            asyncio.run(main())
        self.assertEqual(caught.exception.code, grpc.StatusCode.UNAVAILABLE)
        self.assertIn("no frame answered for 1 s", str(caught.exception))

    def test_bad_camera_id(self):
        async def main():
            async with lane_client.AsyncLaneClient(self.server.target, token="") as client:
                with self.assertRaises(ValueError):
                    client.stream("c" * 129, FRAMES, config=CONFIG)
                with self.assertRaises(ValueError):
                    await client.create_session("bad id", CONFIG)
                with self.assertRaises(ValueError):
                    await client.detect("bad/id?", FRAMES[0])
        asyncio.run(main())
        self.assertEqual(sum(self.server.calls.values()), 0)


if __name__ == "__main__":
    unittest.main()
