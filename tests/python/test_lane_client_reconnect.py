"""The Python client against a real lane-server that restarts (exactly once
across reconnections, lane ids carried by the resume state), its asyncio
client, and its security (TLS, Bearer tokens). Run by test_lane_client.py,
which imports these classes (ctest `python_client`); the set-up both share
is lane_client_test_support.py.
"""

import glob
import os
import shutil
import signal
import subprocess
import sys
import threading
import time
import unittest

import lane_client_test_support as support
from lane_client_test_support import (JPEGS, LANE_TOOL, MISSING, PACKAGE_DIR, SYNTHETIC, Server,
                                      grpc)

# Bound by setUpModule (lane_client_test_support.set_up).
TMP = None
lane_client = None
pb2 = None


def setUpModule():
    global TMP, lane_client, pb2
    if MISSING:
        raise unittest.SkipTest(MISSING)
    support.set_up()
    TMP, lane_client, pb2 = support.TMP, support.lane_client, support.pb2


class ReconnectTest(unittest.TestCase):
    """The stream survives the server's restart on the same port."""

    def setUp(self):
        # The restarted process is another replica: like the replicas of a
        # deployment, it holds the same resume-state key.
        self.server = Server(env={"LANE_RESUME_STATE_KEYS": "5a" * 32}).start()
        self.client = lane_client.LaneClient(self.server.target, token="")

    def tearDown(self):
        self.client.close()
        self.server.kill()

    def restart_mid_stream(self, stop, camera, config, count=40, window=4, at=10):
        frames = [JPEGS[i % len(JPEGS)] for i in range(count)]
        stream = self.client.stream(camera, frames, window=window, config=config)
        ids, restarted_after = [], None
        for response in stream:
            ids.append(response.frame_id)
            self.assertEqual(response.status.code, pb2.FRAME_CODE_OK, response.status.message)
            self.assertTrue(response.lanes)
            if len(ids) == at:
                stop()
                self.server.start()  # the same port
                restarted_after = len(ids)
        self.assertEqual(restarted_after, at)
        self.assertEqual(ids, list(range(count)), "each frame answered once, in order")
        self.assertGreaterEqual(stream.connections, 2, stream.failures)
        self.assertTrue(stream.failures)
        return stream

    def test_survives_a_killed_server(self):
        # A camera the restarted server does not know: the client re-creates
        # its session from the config it read with GetSession.
        self.client.create_session("py-restart", SYNTHETIC)
        stream = self.restart_mid_stream(self.server.kill, "py-restart", None)
        # The killed server had frames in flight (window 4, 10 of 40 answered).
        self.assertGreaterEqual(stream.resent, 1)
        self.assertIn("UNAVAILABLE", " ".join(stream.failures))
        # The new server answered the frames after the 10th, less those whose
        # answers from the old server were already on their way (at most the window).
        processed = self.client.get_session("py-restart").frames_processed
        self.assertLessEqual(processed, 40 - 10)
        self.assertGreaterEqual(processed, 40 - 10 - 4)

    def test_lane_ids_go_on_across_a_killed_server(self):
        # A rendered drive: the restarted server (another process, as another
        # replica would be) takes the tracker's state from the stream's first
        # request, so the lanes keep their ids and stay confirmed.
        drive = os.path.join(TMP, "drive")
        subprocess.run([LANE_TOOL, "render", "--config", SYNTHETIC, "--sequence", "--count", "60",
                        "--seed", "3", "--output", drive, "--format", "jpg"],
                       check=True, stdout=subprocess.DEVNULL)
        frames = []
        # The drive's first second (its events are spread over its length: a
        # 60-frame drive holds 4 boundaries steadily in frames 2-27).
        for path in sorted(glob.glob(os.path.join(drive, "*.jpg")))[:27]:
            with open(path, "rb") as f:
                frames.append(f.read())
        stream = self.client.stream("py-resume", frames, window=4, config=SYNTHETIC)
        responses = []
        for response in stream:
            responses.append(response)
            if len(responses) == 12:
                self.server.kill()
                self.server.start()  # the same port, a new process
        self.assertEqual([r.frame_id for r in responses], list(range(27)))
        self.assertGreaterEqual(stream.tracking.resumes, 1, stream.failures)
        self.assertEqual(stream.tracking.resumes_refused, 0)
        self.assertGreater(stream.tracking.resume_states, 0)
        before = {lane.id for lane in responses[11].lanes if lane.confirmed}
        self.assertGreaterEqual(len(before), 2)
        for response in responses[16:]:
            ids = {lane.id for lane in response.lanes if lane.confirmed}
            self.assertTrue(ids, f"frame {response.frame_id}: no confirmed lane")
            self.assertLessEqual(ids, before, f"frame {response.frame_id}: new ids {ids - before}")

    def test_survives_a_drained_server(self):
        stream = self.restart_mid_stream(self.server.stop, "py-drain", SYNTHETIC)
        self.assertIn("UNAVAILABLE", " ".join(stream.failures))

    def test_stalled_server_is_retried(self):
        # SIGSTOP: the connection stays open but nothing is answered.
        frames = [JPEGS[i % len(JPEGS)] for i in range(20)]
        stream = self.client.stream("default", frames, window=4, stall_timeout=1.0)
        ids = []
        for response in stream:
            ids.append(response.frame_id)
            if len(ids) == 5:
                self.server.proc.send_signal(signal.SIGSTOP)
                threading.Timer(3.0, self.server.proc.send_signal, (signal.SIGCONT,)).start()
        self.assertEqual(ids, list(range(20)))
        self.assertIn("stalled", " ".join(stream.failures))
        self.assertGreaterEqual(stream.connections, 2)

    def test_gives_up_when_the_server_stays_away(self):
        self.server.kill()
        started = time.monotonic()
        with self.assertRaises(lane_client.StreamError) as caught:
            list(self.client.stream("default", JPEGS, give_up_after=1.0))
        self.assertLess(time.monotonic() - started, 30)
        self.assertEqual(caught.exception.code, grpc.StatusCode.UNAVAILABLE)
        self.assertIn("no frame answered", str(caught.exception))


class AsyncClientTest(unittest.TestCase):
    """AsyncLaneClient (grpc.aio): the blocking client's calls and stream,
    awaited; a restarted server mid-stream; the command line."""

    def setUp(self):
        self.server = Server().start()

    def tearDown(self):
        self.server.kill()

    def run_async(self, coroutine):
        import asyncio
        return asyncio.run(coroutine)

    def test_sessions_detect_and_stream(self):
        async def main():
            async with lane_client.AsyncLaneClient(self.server.target, token="") as client:
                created = await client.create_session("aio", SYNTHETIC)
                self.assertEqual(created.outcome, pb2.CREATE_OUTCOME_CREATED)
                self.assertIn("aio", [s.camera_id for s in await client.list_sessions()])
                response = await client.detect("aio", JPEGS[0], frame_id=7)
                self.assertEqual(response.frame_id, 7)
                self.assertTrue(response.lanes)
                with self.assertRaises(lane_client.InvalidFrameError):
                    await client.detect("aio", b"\xff\xd8 not a jpeg")
                with self.assertRaises(lane_client.SessionNotFoundError):
                    await client.get_session("no-such-camera")
                # A list, with a bad frame in the middle: answered in place.
                frames = [JPEGS[i % len(JPEGS)] for i in range(12)]
                frames[5] = b"\xff\xd8 broken"
                stream = client.stream("aio", frames, window=3)
                responses = [r async for r in stream]
                self.assertEqual([r.frame_id for r in responses], list(range(12)))
                self.assertEqual(responses[5].status.code, pb2.FRAME_CODE_INVALID_ARGUMENT)
                self.assertTrue(all(r.status.code == pb2.FRAME_CODE_OK
                                    for i, r in enumerate(responses) if i != 5))
                self.assertEqual(stream.connections, 1)

                # An async source (a camera read without blocking the loop).
                async def camera():
                    for i in range(6):
                        await asyncio.sleep(0.005)
                        yield (100 + i, JPEGS[i % len(JPEGS)])
                import asyncio
                ids = [r.frame_id async for r in client.stream("aio", camera())]
                self.assertEqual(ids, list(range(100, 106)))
                await client.delete_session("aio")
        self.run_async(main())

    def test_stream_survives_a_killed_server(self):
        frames = [JPEGS[i % len(JPEGS)] for i in range(30)]

        async def main():
            async with lane_client.AsyncLaneClient(self.server.target, token="") as client:
                stream = client.stream("aio-restart", frames, window=4, config=SYNTHETIC)
                ids = []
                async for response in stream:
                    ids.append(response.frame_id)
                    self.assertEqual(response.status.code, pb2.FRAME_CODE_OK)
                    if len(ids) == 8:
                        self.server.kill()
                        self.server.start()  # the same port
                return stream, ids
        stream, ids = self.run_async(main())
        self.assertEqual(ids, list(range(30)), "each frame answered once, in order")
        self.assertGreaterEqual(stream.connections, 2, stream.failures)
        self.assertIn("UNAVAILABLE", " ".join(stream.failures))
        self.assertGreaterEqual(stream.tracking.resumes, 1)  # the state went with the new call

    def test_closing_the_stream_early_cancels_the_call(self):
        async def main():
            async with lane_client.AsyncLaneClient(self.server.target, token="") as client:
                stream = client.stream("default", [JPEGS[0]] * 1000, window=4)
                async for response in stream:
                    if response.frame_id == 3:
                        break
                await stream.aclose()
                return stream.frames
        self.assertEqual(self.run_async(main()), 4)
        # The server is still there and serves the next call.
        with lane_client.LaneClient(self.server.target, token="") as client:
            self.assertTrue(client.detect("default", JPEGS[0]).lanes)

    def test_command_line(self):
        env = dict(os.environ, PYTHONPATH=PACKAGE_DIR)

        def cli(*args):
            return subprocess.run([sys.executable, "-m", "lane_client", "--target",
                                   self.server.target] + list(args), env=env,
                                  stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                  universal_newlines=True, timeout=60)
        health = cli("health")
        self.assertEqual(health.returncode, 0, health.stderr)
        self.assertIn('"SERVING"', health.stdout)
        frame = os.path.join(TMP, "cli-frame.jpg")
        with open(frame, "wb") as f:
            f.write(JPEGS[0])
        detect = cli("detect", "cli-cam", frame, "--config", SYNTHETIC)
        self.assertEqual(detect.returncode, 0, detect.stderr)
        import json
        self.assertTrue(json.loads(detect.stdout)["lanes"])
        listed = cli("session", "list")
        self.assertIn('"camera_id": "cli-cam"', listed.stdout)
        missing = cli("session", "get", "no-such-camera")
        self.assertEqual(missing.returncode, 1)
        self.assertIn("NOT_FOUND", missing.stderr)
        usage = cli("session")
        self.assertEqual(usage.returncode, 2)


class SecurityTest(unittest.TestCase):
    """Bearer token and TLS with a CA that openssl makes now."""

    @classmethod
    def setUpClass(cls):
        if shutil.which("openssl") is None:
            raise unittest.SkipTest("openssl is missing: the TLS test is skipped")
        cls.dir = os.path.join(TMP, "tls")
        os.makedirs(cls.dir, exist_ok=True)
        script = (
            "openssl req -x509 -newkey rsa:2048 -nodes -keyout ca.key -out ca.crt -days 2 "
            "-subj /CN=lane-python-test-ca && "
            "openssl req -newkey rsa:2048 -nodes -keyout server.key -out server.csr "
            "-subj /CN=localhost && "
            "printf 'subjectAltName=IP:127.0.0.1,DNS:localhost\\n' > server.ext && "
            "openssl x509 -req -in server.csr -CA ca.crt -CAkey ca.key -CAcreateserial "
            "-out server.crt -days 2 -extfile server.ext")
        done = subprocess.run(script, shell=True, cwd=cls.dir, stdout=subprocess.PIPE,
                              stderr=subprocess.STDOUT, universal_newlines=True)
        if done.returncode != 0:
            raise AssertionError(f"openssl failed:\n{done.stdout}")
        cls.ca = os.path.join(cls.dir, "ca.crt")
        cls.server = Server(f"--tls_cert={cls.dir}/server.crt", f"--tls_key={cls.dir}/server.key",
                            env={"LANE_AUTH_TOKENS": "py-secret,other"}).start()

    @classmethod
    def tearDownClass(cls):
        cls.server.stop()

    def test_tls_and_token(self):
        with lane_client.LaneClient(self.server.target, token="py-secret", ca=self.ca) as client:
            self.assertTrue(client.server_info().version)
            response = client.detect("default", JPEGS[0])
            self.assertTrue(response.lanes)
            self.assertEqual(len(list(client.stream("default", JPEGS))), len(JPEGS))
        with open(self.ca, "rb") as f:  # PEM bytes instead of a path
            with lane_client.LaneClient(self.server.target, token="other", ca=f.read()) as client:
                self.assertTrue(client.server_info().version)

    def test_missing_or_wrong_token(self):
        for token in ("", "wrong"):
            with lane_client.LaneClient(self.server.target, token=token, ca=self.ca) as client:
                with self.assertRaises(lane_client.UnauthenticatedError) as caught:
                    client.server_info()
                self.assertEqual(caught.exception.code, grpc.StatusCode.UNAUTHENTICATED)
                with self.assertRaises(lane_client.LaneError) as caught:
                    list(client.stream("default", JPEGS))
                self.assertEqual(caught.exception.code, grpc.StatusCode.UNAUTHENTICATED)

    def test_token_from_environment(self):
        os.environ["LANE_TOKEN"] = "py-secret"
        try:
            with lane_client.LaneClient(self.server.target, ca=self.ca) as client:
                self.assertTrue(client.server_info().version)
        finally:
            del os.environ["LANE_TOKEN"]

    def test_plaintext_client_fails(self):
        with lane_client.LaneClient(self.server.target, token="py-secret", timeout=5) as client:
            with self.assertRaises(lane_client.LaneError) as caught:
                client.server_info()
            self.assertEqual(caught.exception.code, grpc.StatusCode.UNAVAILABLE)
