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
is missing. stdlib unittest only. This file holds the calls and streams
against one server and the stubs' checks; test_lane_client_reconnect.py
(restarts, asyncio, security) is imported below, so that this one run holds
every test; lane_client_test_support.py what both share.
"""

import os
import subprocess
import sys
import time
import unittest

import lane_client_test_support as support
from lane_client_test_support import (JPEGS, MISSING, NO_NUMPY, PACKAGE_DIR, SKIP_EXIT,
                                      SYNTHETIC, Server, grpc, ground_offsets, lanes_of,
                                      lateral_positions, np, png_bytes, road_frame)

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


# Restarts, asyncio and security: their own file, run with these.
from test_lane_client_reconnect import (AsyncClientTest, ReconnectTest,  # noqa: E402,F401
                                        SecurityTest)

if __name__ == "__main__":
    if MISSING:
        print(f"SKIP: {MISSING}")
        sys.exit(SKIP_EXIT)
    unittest.main()
