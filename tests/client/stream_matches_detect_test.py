#!/usr/bin/env python3
"""`lane-client stream` writes the lines `lane detect --track` writes.

A rendered drive (lane render --sequence, JPEG frames) goes through `lane
detect --track` and, as one camera of a tracked session, through a real
`lane-server` on a loopback port with `lane-client stream --window 1 --fps
30`: one frame in flight, so that the server's tracker measures each frame
with the state after the frame before, as lane detect does, and capture times
1/30 s apart, the rate lane detect assumes. Every record must be the same
once `timing_ms` and the client's own fields are set aside: the same keys
(lanes[].inferred, width, height, mode among them), the same lanes with the
same ids, flags, colours and types, the same ego lane.

Exact where it can be. The server's tracker is timed by the capture times,
Unix seconds (1.7e9 s: steps of 2.4e-7 s in a double), lane detect's from 0:
the Kalman filter's time steps differ in their last bits, and a confirmed
lane's curve (drawn from its filtered curve) then now and then rounds the
other way in its last printed digit. So curves and the ego lane's figures
may differ by one unit of the last decimal, and the ego lane's lateral
speed, which needs 0.2 s of history (six frame intervals at 30/s: the
interval's last bit decides, for either tool), may start a frame later on
one side (0 there, and no departure). Everything else is compared exactly.

Usage: stream_matches_detect_test.py LANE LANE_SERVER LANE_CLIENT SOURCE_DIR
"""
import json
import os
import socket
import subprocess
import sys
import tempfile
import time

LANE, SERVER, CLIENT, SRC = sys.argv[1:5]
CONFIG = os.path.join(SRC, "configs", "synthetic.json")
FRAMES = 24

# Fields only lane-client writes (docs/client.md); timing_ms differs anyway.
CLIENT_ONLY = {"camera_id", "frame_id", "capture_time_unix_ns", "server_receive_time_unix_ns",
               "server_send_time_unix_ns", "status", "error", "calibration_version",
               "latency_ms", "attempts", "connection"}
# One unit of the last decimal written (docs/results-format.md).
POINT_UNIT = {"image": 1e-3, "ipm": 1e-3, "ground": 1e-4}
EGO_UNIT = {"offset_m": 1e-3, "width_m": 1e-3, "heading_deg": 1e-3, "curvature_per_m": 1e-6,
            "left_distance_m": 1e-3, "right_distance_m": 1e-3, "offset_rate_mps": 1e-3}

failures = []


def check(condition, message):
    if not condition:
        failures.append(message)
        print("FAIL:", message, flush=True)
    return condition


def run(args, timeout=120):
    return subprocess.run(args, capture_output=True, text=True, timeout=timeout)


def lines_of(text):
    return [json.loads(line) for line in text.splitlines() if line.strip()]


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def near(a, b, unit):
    return abs(a - b) <= 1.5 * unit


def compare_lane(where, a, b):
    check(set(a) == set(b), "%s: keys %s vs %s" % (where, sorted(a), sorted(b)))
    for key in a:
        if key in POINT_UNIT:
            same = all(near(p, q, POINT_UNIT[key]) for pa, pb in zip(a[key], b[key])
                       for p, q in zip(pa, pb))
            check(same, "%s.%s: %s vs %s" % (where, key, a[key], b[key]))
        elif key == "score":
            check(near(a[key], b[key], 1e-4), "%s.score: %s vs %s" % (where, a[key], b[key]))
        elif key in b:
            check(a[key] == b[key], "%s.%s: %s vs %s" % (where, key, a[key], b[key]))


def compare_ego(where, a, b, rate_starting):
    if a is None or b is None:
        check(a is None and b is None, "%s: ego %s vs %s" % (where, a, b))
        return
    check(set(a) == set(b), "%s: ego keys %s vs %s" % (where, sorted(a), sorted(b)))
    # The lateral speed starting a frame later on one side (see the top).
    starts = rate_starting and 0.0 in (a["offset_rate_mps"], b["offset_rate_mps"])
    for key in a:
        if key == "offset_rate_mps" and starts:
            continue
        if key == "departing" and starts:
            continue
        if key in EGO_UNIT:
            check(near(a[key], b[key], EGO_UNIT[key]),
                  "%s: ego.%s %s vs %s" % (where, key, a[key], b[key]))
        elif key in b:
            check(a[key] == b[key], "%s: ego.%s %s vs %s" % (where, key, a[key], b[key]))


def compare(detected, streamed):
    check(len(detected) == FRAMES and len(streamed) == FRAMES,
          "%d and %d records for %d frames" % (len(detected), len(streamed), FRAMES))
    exact = 0
    # Neither side had a lateral speed in the frame before: one may start now.
    rate_starting = True
    for i, (d, s) in enumerate(zip(detected, streamed)):
        where = "frame %d (%s)" % (i, d.get("frame"))
        check(s.get("status") == "OK", "%s: status %s" % (where, s.get("status")))
        check(s.get("frame_id") == i and s.get("attempts") == 1 and s.get("connection") == 1,
              "%s: frame_id %s, attempts %s, connection %s"
              % (where, s.get("frame_id"), s.get("attempts"), s.get("connection")))
        timing = s.get("timing_ms", {})
        check(set(d["timing_ms"]) <= set(timing) and "queue_wait" in timing and
              timing.get("detect") == timing.get("total"),
              "%s: timing_ms keys %s" % (where, sorted(timing)))
        shared = {k: v for k, v in s.items() if k not in CLIENT_ONLY and k != "timing_ms"}
        mine = {k: v for k, v in d.items() if k != "timing_ms"}
        check(set(shared) == set(mine),
              "%s: keys %s vs lane detect's %s" % (where, sorted(shared), sorted(mine)))
        exact += shared == mine
        for key in mine:
            if key == "lanes":
                if check(len(s["lanes"]) == len(d["lanes"]), "%s: %d lanes vs %d" %
                         (where, len(s["lanes"]), len(d["lanes"]))):
                    for j, (a, b) in enumerate(zip(d["lanes"], s["lanes"])):
                        compare_lane("%s lane %d" % (where, j), a, b)
            elif key == "ego":
                compare_ego(where, d["ego"], s.get("ego"), rate_starting)
            elif key in shared:
                check(shared[key] == mine[key], "%s: %s %s vs %s" % (where, key, shared[key], mine[key]))
        rate_starting = not any(r.get("ego") and r["ego"]["offset_rate_mps"] != 0 for r in (d, s))
    return exact


with tempfile.TemporaryDirectory() as tmp:
    frames = os.path.join(tmp, "frames")
    r = run([LANE, "render", "--config", CONFIG, "--sequence", "--count", str(FRAMES), "--seed", "7",
             "--format", "jpg", "--output", frames])
    check(r.returncode == 0, "lane render: " + r.stderr[-500:])
    frame_list = os.path.join(frames, "list.txt")
    r = run([LANE, "detect", "--config", CONFIG, "--track", "-q", frame_list])
    check(r.returncode == 0, "lane detect --track: exit %d: %s" % (r.returncode, r.stderr[-500:]))
    detected = lines_of(r.stdout)

    port = free_port()
    server = subprocess.Popen([SERVER, "--address=127.0.0.1:%d" % port, "--metrics_address=",
                               "--workers=2"], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                              text=True)
    try:
        healthy = False
        for _ in range(100):
            if run([CLIENT, "health", "--target", "127.0.0.1:%d" % port]).returncode == 0:
                healthy = True
                break
            time.sleep(0.1)
        check(healthy, "lane-server did not become healthy")
        r = run([CLIENT, "stream", "--target", "127.0.0.1:%d" % port, "--camera", "drive",
                 "--config", CONFIG, "--window", "1", "--fps", "30", "-q", frame_list])
        check(r.returncode == 0, "lane-client stream: exit %d: %s" % (r.returncode, r.stderr[-500:]))
        streamed = lines_of(r.stdout)
    finally:
        server.terminate()
        server.wait(timeout=30)

    # What is compared: tracked lanes of every kind, and the ego lane.
    lanes = [lane for record in detected for lane in record.get("lanes", [])]
    check(sum(lane.get("predicted", False) for lane in lanes) > 0 and
          sum(lane.get("refit", False) for lane in lanes) > 0 and
          sum(lane.get("confirmed", False) for lane in lanes) > 0 and
          sum(1 for record in detected if record.get("ego")) > 0,
          "the drive lacks predicted, refitted or confirmed lanes, or an ego lane")
    exact = compare(detected, streamed)

if failures:
    print("%d failures" % len(failures))
    sys.exit(1)
print("lane-client stream vs lane detect --track: %d frames, %d lanes, %d records identical "
      "(timing_ms and the client's fields aside), the rest within the last digit"
      % (len(detected), len(lanes), exact))
