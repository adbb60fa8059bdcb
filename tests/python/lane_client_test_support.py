#!/usr/bin/env python3
"""What the Python client's tests against a real lane-server share
(test_lane_client.py, test_lane_client_reconnect.py): the environment ctest
sets, a lane-server process, synthetic frames, and the one-time set-up
(stubs, rendered JPEG frames) both test modules call from setUpModule.
"""

import atexit
import glob
import os
import shutil
import signal
import struct
import subprocess
import sys
import tempfile
import threading
import unittest
import zlib

SKIP_EXIT = 77
MISSING = None
try:
    import grpc  # noqa: F401  (python3-grpcio)
    import google.protobuf  # noqa: F401  (python3-protobuf)
except ImportError as e:
    grpc = None
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

# Set up by set_up(), once for both test modules.
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

def set_up():
    """The stubs, the lane_client module and the frames; once per process,
    whichever test module asks first. The folder goes at exit."""
    global TMP, lane_client, pb2
    if TMP is not None:
        return
    if MISSING:
        raise unittest.SkipTest(MISSING)
    if not SERVER or not os.access(SERVER, os.X_OK):
        raise AssertionError(f"LANE_SERVER={SERVER!r} is not an executable lane-server "
                             "(ctest sets it; build the lane-server target)")
    TMP = tempfile.mkdtemp(prefix="lane_python_test_")
    atexit.register(shutil.rmtree, TMP, ignore_errors=True)
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
