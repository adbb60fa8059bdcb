#!/usr/bin/env python3
"""The Python client (client/python/lane_client) against a real lane-server.

Run by ctest as `python_client` (tests/python/CMakeLists.txt), which sets
  LANE_SERVER        the built lane-server (required)
  LANE_TOOL          the built `lane` tool, whose `render` makes the frames
  LANE_SOURCE_DIR    the checkout (configs/, proto/, client/python/)
  LANE_CLIENT_STUBS  the stubs the build generated; when they are missing the
                     test generates its own with `lane_client.generate`.
Every server is started on a free loopback port (--address 127.0.0.1:0, the
port read from its start-up line) with no metrics endpoint, and stopped by
the test. Exits 77 (ctest: skipped) when python3-grpcio or python3-protobuf
is missing. stdlib unittest only.
"""

import glob
import os
import shutil
import signal
import struct
import subprocess
import sys
import tempfile
import threading
import time
import unittest
import zlib

SKIP_EXIT = 77
MISSING = None
try:
    import grpc  # noqa: F401  (python3-grpcio)
    import google.protobuf  # noqa: F401  (python3-protobuf)
except ImportError as e:
    MISSING = (f"{e}: the Python client needs Debian's python3-grpcio and python3-protobuf "
               "(scripts/install-deps.sh installs them)")
try:
    import numpy as np
except ImportError:
    np = None
NO_NUMPY = "python3-numpy is not installed: array frames are not tested"

SOURCE_DIR = os.environ.get("LANE_SOURCE_DIR") or os.path.abspath(
    os.path.join(os.path.dirname(__file__), "..", ".."))
PACKAGE_DIR = os.path.join(SOURCE_DIR, "client", "python")
SYNTHETIC = os.path.join(SOURCE_DIR, "configs", "synthetic.json")
SERVER = os.environ.get("LANE_SERVER", "")
LANE_TOOL = os.environ.get("LANE_TOOL", "")
sys.path.insert(0, PACKAGE_DIR)

# Set up by setUpModule.
TMP = None
JPEGS = []        # rendered synthetic road frames (JPEG bytes)
lane_client = None
pb2 = None


# ---------------------------------------------------------------------------
# A lane-server process
# ---------------------------------------------------------------------------

class Server:
    """A lane-server on 127.0.0.1; start() again restarts it on the same port."""

    def __init__(self, *args, env=None):
        self.args = list(args)
        self.env = dict(os.environ, **(env or {}))
        self.port = 0
        self.proc = None
        self.log = []

    @property
    def target(self):
        return f"127.0.0.1:{self.port}"

    def start(self, timeout=60):
        command = [SERVER, f"--address=127.0.0.1:{self.port}", "--metrics_address=",
                   "--workers=2", f"--default_config={SYNTHETIC}"] + self.args
        self.proc = subprocess.Popen(command, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                                     stderr=subprocess.PIPE, env=self.env,
                                     universal_newlines=True)
        ready = threading.Event()
        port = []

        def read(stream, log):
            for line in stream:
                log.append(line.rstrip("\n"))
                if not ready.is_set() and "gRPC on port " in line:
                    port.append(int(line.split("gRPC on port ")[1].split(",")[0].split()[0]))
                    ready.set()
            stream.close()
            ready.set()  # exited

        threading.Thread(target=read, args=(self.proc.stderr, self.log), daemon=True).start()
        if not ready.wait(timeout) or not port:
            self.kill()
            raise AssertionError(f"lane-server did not start: {' '.join(command)}\n"
                                 + "\n".join(self.log))
        self.port = port[0]
        return self

    def kill(self):
        """SIGKILL: a crash. Frames in flight are lost."""
        if self.proc and self.proc.poll() is None:
            self.proc.kill()
        if self.proc:
            self.proc.wait(30)

    def stop(self):
        """SIGTERM: drain, then exit; SIGKILL after 30 s."""
        if self.proc and self.proc.poll() is None:
            self.proc.send_signal(signal.SIGTERM)
            try:
                self.proc.wait(30)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait(30)


# ---------------------------------------------------------------------------
# Frames
# ---------------------------------------------------------------------------

def road_frame(marking_bgr=(235, 235, 235), road=95, lanes_x=(-1.8, 1.8, 5.4)):
    """A 640x480 BGR frame of a flat road seen by configs/synthetic.json's
    camera, with solid markings 0.15 m wide at lateral offsets lanes_x."""
    import math
    fu, fv, cu, cv = 309.4362, 344.2161, 317.9034, 256.5352
    pitch, height = math.radians(14.0), 2.1798
    rng = np.random.default_rng(7)
    frame = np.clip(road + rng.normal(0, 6, (480, 640, 3)), 0, 255).astype(np.uint8)
    horizon = cv - fv * math.tan(pitch)
    frame[:int(horizon) + 1] = 170
    for v in range(int(horizon) + 4, 480):
        t = (v - cv) / fv
        ahead = height * (math.cos(pitch) - t * math.sin(pitch)) / (t * math.cos(pitch)
                                                                     + math.sin(pitch))
        depth = ahead * math.cos(pitch) + height * math.sin(pitch)
        for x in lanes_x:
            u = cu + fu * x / depth
            half = max(0.6, fu * 0.075 / depth)
            lo, hi = int(round(u - half)), int(round(u + half)) + 1
            lo, hi = max(lo, 0), min(hi, 640)
            if lo < hi:
                frame[v, lo:hi] = marking_bgr
    return frame


def png_bytes(rgb):
    """A PNG file of an H x W x 3 uint8 RGB array (stdlib zlib only)."""
    height, width = rgb.shape[:2]
    rows = b"".join(b"\x00" + rgb[y].tobytes() for y in range(height))

    def chunk(tag, data):
        return (struct.pack(">I", len(data)) + tag + data
                + struct.pack(">I", zlib.crc32(tag + data) & 0xFFFFFFFF))

    header = struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + chunk(b"IDAT", zlib.compress(rows))
            + chunk(b"IEND", b""))


def ground_offsets(response):
    """Lateral offsets of the lanes at their first ground point, metres, 0.1 m steps."""
    return [round(lane.ground.control_points[0].x, 1) for lane in response.lanes]


def lateral_positions(response):
    """The detected lanes' mean lateral offsets on the ground (the mean x of
    their control points, metres), left to right, without predicted lanes."""
    return sorted(sum(p.x for p in lane.ground.control_points) / 4
                  for lane in response.lanes if not lane.predicted)


def lanes_of(response):
    """The detected lanes' image control points (a tracked stream also
    reports predicted lanes: the tracks of earlier frames)."""
    return [[(p.x, p.y) for p in lane.image.control_points]
            for lane in response.lanes if not lane.predicted]


# ---------------------------------------------------------------------------

def setUpModule():
    global TMP, JPEGS, lane_client, pb2
    if MISSING:
        raise unittest.SkipTest(MISSING)
    if not SERVER or not os.access(SERVER, os.X_OK):
        raise AssertionError(f"LANE_SERVER={SERVER!r} is not an executable lane-server "
                             "(ctest sets it; build the lane-server target)")
    TMP = tempfile.mkdtemp(prefix="lane_python_test_")
    stubs = os.environ.get("LANE_CLIENT_STUBS", "")
    if not stubs or not os.path.isfile(os.path.join(stubs, "lane", "v1", "lane_service_pb2.py")):
        # The build did not make them (only lane-server was built): as a user would.
        stubs = os.path.join(TMP, "stubs")
        subprocess.run([sys.executable, "-m", "lane_client.generate", "--quiet", "--out", stubs],
                       cwd=PACKAGE_DIR, check=True)
        os.environ["LANE_CLIENT_STUBS"] = stubs
    import lane_client as module
    lane_client = module
    pb2 = lane_client.load_stubs()[0]

    if LANE_TOOL:
        frames_dir = os.path.join(TMP, "frames")
        subprocess.run([LANE_TOOL, "render", "--config", SYNTHETIC, "--count", "5", "--output",
                        frames_dir, "--format", "jpg", "--num-lanes", "3"],
                       check=True, stdout=subprocess.DEVNULL)
        paths = sorted(glob.glob(os.path.join(frames_dir, "*.jpg")))
        assert len(paths) == 5, paths
        for path in paths:
            with open(path, "rb") as f:
                JPEGS.append(f.read())
    else:
        raise AssertionError("LANE_TOOL is not set: the JPEG frames come from `lane render`")


def tearDownModule():
    if TMP:
        shutil.rmtree(TMP, ignore_errors=True)


class ClientTest(unittest.TestCase):
    """One server for the calls that do not stop it."""

    @classmethod
    def setUpClass(cls):
        cls.server = Server().start()
        cls.client = lane_client.LaneClient(cls.server.target, token="")

    @classmethod
    def tearDownClass(cls):
        cls.client.close()
        cls.server.stop()

    def assert_lanes(self, response, at_least=1):
        self.assertEqual(response.status.code, pb2.FRAME_CODE_OK, response.status.message)
        self.assertGreaterEqual(len(response.lanes), at_least, "no lane found")
        for lane in response.lanes:
            for curve in (lane.image, lane.ipm, lane.ground):
                self.assertEqual(len(curve.control_points), 4)

    # -- sessions -------------------------------------------------------------

    def test_create_session_from_path_dict_and_json(self):
        created = self.client.create_session("py-create", SYNTHETIC)
        self.assertEqual(created.outcome, pb2.CREATE_OUTCOME_CREATED)
        self.assertEqual(created.session.camera_id, "py-create")
        self.assertEqual(created.session.config.camera.image_width, 640)
        import json
        with open(SYNTHETIC) as f:
            as_dict = json.load(f)
        self.assertEqual(self.client.create_session("py-create", as_dict).outcome,
                         pb2.CREATE_OUTCOME_UNCHANGED)
        self.assertEqual(self.client.create_session("py-create", json.dumps(as_dict)).outcome,
                         pb2.CREATE_OUTCOME_UNCHANGED)
        other = dict(as_dict, detector={"mode": "two"})
        with self.assertRaises(lane_client.LaneError) as caught:
            self.client.create_session("py-create", other)
        self.assertEqual(caught.exception.code, grpc.StatusCode.ALREADY_EXISTS)
        replaced = self.client.create_session("py-create", other, replace=True)
        self.assertEqual(replaced.outcome, pb2.CREATE_OUTCOME_REPLACED)
        self.assertGreater(replaced.session.version, created.session.version)
        self.assertIn("py-create", [s.camera_id for s in self.client.list_sessions()])
        self.client.delete_session("py-create")
        with self.assertRaises(lane_client.SessionNotFoundError):
            self.client.get_session("py-create")

    def test_bad_config_is_refused(self):
        with self.assertRaises(lane_client.LaneError) as caught:
            self.client.create_session("py-bad", {"camera": {"image_width": "wide"}})
        self.assertEqual(caught.exception.code, grpc.StatusCode.INVALID_ARGUMENT)
        with self.assertRaises(lane_client.LaneError) as caught:
            self.client.create_session("py-bad", os.path.join(TMP, "no-such-config.json"))
        self.assertIn("no-such-config.json", str(caught.exception))

    def test_server_info(self):
        info = self.client.server_info()
        self.assertTrue(info.version)
        self.assertIn(pb2.PIXEL_FORMAT_BGR8, info.raw_formats)

    # -- detect -----------------------------------------------------------------

    def test_detect_jpeg_bytes(self):
        response = self.client.detect("default", JPEGS[0], frame_id=42)
        self.assert_lanes(response)
        self.assertEqual(response.frame_id, 42)
        self.assertEqual(response.camera_id, "default")
        self.assertGreater(response.calibration_version, 0)

    def test_detect_jpeg_path(self):
        path = os.path.join(TMP, "frame.jpg")
        with open(path, "wb") as f:
            f.write(JPEGS[1])
        self.assert_lanes(self.client.detect("default", path))

    @unittest.skipIf(np is None, NO_NUMPY)
    def test_detect_ndarray_bgr_matches_png_of_same_frame(self):
        frame = road_frame()
        raw = self.client.detect("default", frame)
        self.assert_lanes(raw, at_least=3)
        self.assertEqual(ground_offsets(raw), [-1.8, 1.8, 5.4])  # where they were painted
        encoded = self.client.detect("default", png_bytes(frame[:, :, ::-1]))
        self.assertEqual(lanes_of(raw), lanes_of(encoded))
        # A view that is not contiguous (every other column of a wider array).
        wide = np.repeat(frame, 2, axis=1)
        self.assertEqual(lanes_of(self.client.detect("default", wide[:, ::2])), lanes_of(raw))

    @unittest.skipIf(np is None, NO_NUMPY)
    @unittest.skipIf(np is None, NO_NUMPY)
    def test_hidden_boundary_is_reported_as_inferred(self):
        """With detector.road_model.infer_hidden, the boundary between two
        found ones two lane widths apart is reported with `inferred` set;
        without it, the lanes carry inferred = False."""
        import json
        with open(SYNTHETIC) as f:
            config = json.load(f)
        config.setdefault("detector", {})["road_model"] = {"infer_hidden": True}
        self.client.create_session("py-inferred", config)
        try:
            frame = road_frame(lanes_x=(-5.4, -1.8, 5.4))  # the boundary at 1.8 m is gone
            response = self.client.detect("py-inferred", frame)
            self.assert_lanes(response, at_least=4)
            offsets = ground_offsets(response)
            self.assertEqual(len(offsets), 4, offsets)
            for got, painted in zip(offsets, [-5.4, -1.8, 1.8, 5.4]):
                self.assertAlmostEqual(got, painted, delta=0.15, msg=offsets)
            self.assertEqual([lane.inferred for lane in response.lanes],
                             [False, False, True, False])
            plain = self.client.detect("default", frame)
            self.assertEqual(len(plain.lanes), 3, ground_offsets(plain))
            self.assertFalse(any(lane.inferred for lane in plain.lanes))
        finally:
            self.client.delete_session("py-inferred")

    def test_detect_ndarray_gray(self):
        grey = road_frame()[:, :, 1]
        self.assert_lanes(self.client.detect("default", grey), at_least=2)
        self.assert_lanes(self.client.detect("default", grey[:, :, None]), at_least=2)

    @unittest.skipIf(np is None, NO_NUMPY)
    def test_ndarray_channel_order(self):
        # Yellow markings (blue low) on a grey road; the session detects on
        # the red channel, so only the right channel order finds them.
        frame = road_frame(marking_bgr=(40, 230, 240))
        bgr = self.client.detect("default", frame)
        self.assertEqual(ground_offsets(bgr), [-1.8, 1.8, 5.4])
        rgb = self.client.detect("default", frame[:, :, ::-1], rgb=True)
        self.assertEqual(lanes_of(rgb), lanes_of(bgr))
        # The same array taken as RGB puts the dark blue values in red.
        swapped = self.client.detect("default", frame, rgb=True)
        self.assertNotEqual(ground_offsets(swapped), [-1.8, 1.8, 5.4])

    @unittest.skipIf(np is None, NO_NUMPY)
    def test_bad_arrays_are_refused_locally(self):
        with self.assertRaises(TypeError):
            self.client.detect("default", np.zeros((480, 640, 3), np.float32))
        with self.assertRaises(TypeError):
            self.client.detect("default", np.zeros((480, 640, 4), np.uint8))
        with self.assertRaises(TypeError):
            self.client.detect("default", 12)

    @unittest.skipIf(np is None, NO_NUMPY)
    def test_detect_wrong_size_array(self):
        with self.assertRaises(lane_client.InvalidFrameError) as caught:
            self.client.detect("default", np.zeros((240, 320, 3), np.uint8))
        self.assertEqual(caught.exception.code, grpc.StatusCode.INVALID_ARGUMENT)

    def test_detect_bad_frame(self):
        with self.assertRaises(lane_client.InvalidFrameError) as caught:
            self.client.detect("default", b"this is not a jpeg")
        self.assertEqual(caught.exception.code, grpc.StatusCode.INVALID_ARGUMENT)
        self.assertIn("JPEG", str(caught.exception))

    def test_detect_with_config_creates_the_session(self):
        self.assert_lanes(self.client.detect("py-detect-config", JPEGS[2], config=SYNTHETIC))
        self.assertEqual(self.client.get_session("py-detect-config").camera_id,
                         "py-detect-config")

    def test_unknown_camera_raises_a_clear_error(self):
        with self.assertRaises(lane_client.SessionNotFoundError) as caught:
            self.client.detect("no-such-camera", JPEGS[0])
        self.assertIn("no-such-camera", str(caught.exception))
        with self.assertRaises(lane_client.SessionNotFoundError) as caught:
            list(self.client.stream("no-such-camera", JPEGS))
        self.assertIn("no-such-camera", str(caught.exception))
        self.assertIn("create_session", str(caught.exception))

    # -- stream -----------------------------------------------------------------

    def test_stream_answers_every_frame_in_order(self):
        frames = JPEGS * 5
        stream = self.client.stream("default", frames, window=4)
        responses = list(stream)
        self.assertEqual([r.frame_id for r in responses], list(range(len(frames))))
        for response in responses:
            self.assert_lanes(response)
        # The same frame gives the same lanes whenever it is sent: as many,
        # in the same places. (Not the same control points or scores: a
        # stream is tracked, a confirmed lane is drawn from its track's
        # filtered curve, which the frames in between moved, and it may be
        # refitted in its window instead of searched for, docs/tracking.md.)
        first, again = lateral_positions(responses[0]), lateral_positions(responses[5])
        self.assertTrue(first)
        self.assertEqual(len(first), len(again))
        for a, b in zip(first, again):
            self.assertLess(abs(a - b), 0.35)
        self.assertTrue(any(lane.refit for r in responses for lane in r.lanes))
        self.assertEqual((stream.frames, stream.connections, stream.resent), (len(frames), 1, 0))

    def test_stream_frame_ids_and_arrays(self):
        items = [(100 + 3 * i, frame) for i, frame in enumerate(JPEGS)]
        if np is not None:
            items.append((500, road_frame()))
        responses = list(self.client.stream("default", items, window=2))
        self.assertEqual([r.frame_id for r in responses], [i for i, _ in items])
        for response in responses:
            self.assert_lanes(response)

    def test_stream_bad_frame_does_not_end_it(self):
        frames = list(JPEGS)
        frames.insert(2, b"\xff\xd8 truncated, not a JPEG")
        responses = list(self.client.stream("default", frames))
        self.assertEqual(len(responses), len(frames))
        self.assertEqual([r.frame_id for r in responses], list(range(len(frames))))
        codes = [r.status.code for r in responses]
        self.assertEqual(codes[2], pb2.FRAME_CODE_INVALID_ARGUMENT)
        self.assertTrue(responses[2].status.message)
        self.assertEqual(codes[:2] + codes[3:], [pb2.FRAME_CODE_OK] * len(JPEGS))

    def test_stream_window_bounds_frames_in_flight(self):
        taken = [0]

        def source():
            for i in range(30):
                taken[0] += 1
                yield JPEGS[i % len(JPEGS)]

        window = 3
        for answered, response in enumerate(self.client.stream("default", source(),
                                                               window=window), 1):
            # At most `window` frames taken and not answered.
            self.assertLessEqual(taken[0] - answered, window)
            time.sleep(0.005)
        self.assertEqual(answered, 30)

    def test_stream_with_config_creates_the_session(self):
        responses = list(self.client.stream("py-stream-config", JPEGS, config=SYNTHETIC))
        self.assertEqual(len(responses), len(JPEGS))
        self.assertEqual(self.client.get_session("py-stream-config").frames_processed,
                         len(JPEGS))

    def test_stream_source_error_is_raised_after_earlier_answers(self):
        def source():
            yield JPEGS[0]
            yield JPEGS[1]
            raise ValueError("camera unplugged")

        got = []
        with self.assertRaisesRegex(ValueError, "camera unplugged"):
            for response in self.client.stream("default", source()):
                got.append(response.frame_id)
        self.assertEqual(got, [0, 1])

    def test_stream_of_no_frames(self):
        stream = self.client.stream("default", [])
        self.assertEqual(list(stream), [])
        self.assertEqual(stream.connections, 1)

    def test_stream_closed_early(self):
        def endless():
            while True:
                yield JPEGS[0]

        with self.client.stream("default", endless(), window=2) as stream:
            first = [next(stream).frame_id for _ in range(3)]
        self.assertEqual(first, [0, 1, 2])
        # The connection is still good for the next call.
        self.assert_lanes(self.client.detect("default", JPEGS[0]))

    # -- reflection (the grpcurl-like example) ------------------------------------

    def reflect(self, *args):
        return subprocess.run([sys.executable, "-m", "lane_client.reflection", *args],
                              cwd=PACKAGE_DIR, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                              universal_newlines=True, timeout=60)

    def test_reflection_list_describe_and_call(self):
        target = self.server.target
        listed = self.reflect(target, "list")
        self.assertEqual(listed.returncode, 0, listed.stderr)
        self.assertIn("lane.v1.LaneService", listed.stdout.split())
        self.assertIn("grpc.health.v1.Health", listed.stdout.split())
        methods = self.reflect(target, "list", "lane.v1.LaneService")
        self.assertIn("lane.v1.LaneService.StreamFrames", methods.stdout.split())
        described = self.reflect(target, "describe", "lane.v1.LaneService")
        self.assertIn("rpc StreamFrames ( stream .lane.v1.FrameRequest ) returns "
                      "( stream .lane.v1.FrameResponse );", described.stdout)
        message = self.reflect(target, "describe", "lane.v1.CameraCalibration")
        self.assertIn("optional double fu = 1;", message.stdout)
        info = self.reflect(target, "lane.v1.LaneService/GetServerInfo")
        self.assertEqual(info.returncode, 0, info.stderr)
        import json
        self.assertEqual(json.loads(info.stdout)["version"], self.client.server_info().version)
        session = self.reflect("-d", '{"camera_id": "default"}', target,
                               "lane.v1.LaneService/GetSession")
        self.assertEqual(json.loads(session.stdout)["cameraId"], "default")
        missing = self.reflect("-d", '{"camera_id": "nope"}', target,
                               "lane.v1.LaneService/GetSession")
        self.assertEqual(missing.returncode, 1)
        self.assertIn("NOT_FOUND", missing.stderr)

    def test_reflection_streams_a_frame(self):
        import base64
        import json
        request = {"cameraId": "default", "frameId": 7,
                   "encoded": base64.b64encode(JPEGS[0]).decode()}
        done = self.reflect("-d", json.dumps([request, dict(request, frameId=8)]),
                            self.server.target, "lane.v1.LaneService/StreamFrames")
        self.assertEqual(done.returncode, 0, done.stderr)
        decoder = json.JSONDecoder()
        text, responses = done.stdout.strip(), []
        while text:
            obj, end = decoder.raw_decode(text)
            responses.append(obj)
            text = text[end:].strip()
        self.assertEqual([r["frameId"] for r in responses], ["7", "8"])
        self.assertTrue(responses[0]["lanes"])


class StubsTest(unittest.TestCase):
    """Generating and finding the stubs, as a user does."""

    def run_python(self, code, env):
        return subprocess.run([sys.executable, "-c", code], cwd=PACKAGE_DIR,
                              env=dict(os.environ, **env), stdout=subprocess.PIPE,
                              stderr=subprocess.PIPE, universal_newlines=True, timeout=60)

    def test_generate_into_a_directory_and_use_it(self):
        out = os.path.join(TMP, "generated")
        done = subprocess.run([sys.executable, "-m", "lane_client.generate", "--out", out],
                              cwd=PACKAGE_DIR, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                              universal_newlines=True, timeout=60)
        self.assertEqual(done.returncode, 0, done.stderr)
        self.assertIn(f"LANE_CLIENT_STUBS={out}", done.stdout)
        used = self.run_python(
            "import lane_client, warnings; warnings.simplefilter('error');"
            "pb2, _ = lane_client.load_stubs(); print(pb2.__file__);"
            "print(pb2.CameraCalibration().HasField('fu'))",
            {"LANE_CLIENT_STUBS": out})
        self.assertEqual(used.returncode, 0, used.stderr)
        self.assertTrue(used.stdout.startswith(out), used.stdout)
        self.assertIn("False", used.stdout)  # proto3 optional: field presence

    def test_missing_stubs_say_how_to_make_them(self):
        empty = os.path.join(TMP, "empty")
        os.makedirs(empty, exist_ok=True)
        done = self.run_python("import lane_client; lane_client.LaneClient('127.0.0.1:1')",
                               {"LANE_CLIENT_STUBS": empty})
        self.assertNotEqual(done.returncode, 0)
        self.assertIn("StubsNotFoundError", done.stderr)
        self.assertIn("python3 -m lane_client.generate", done.stderr)


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


if __name__ == "__main__":
    if MISSING:
        print(f"SKIP: {MISSING}")
        sys.exit(SKIP_EXIT)
    unittest.main()
