#!/usr/bin/env python3
"""Live and paced inputs of `lane detect` and `lane-client stream`, for real:

* MJPEG over HTTP served on loopback by a local `ffmpeg -re ... -f mpjpeg
  -listen 1` (paced at 10 frames/s like a camera; Debian's ffmpeg), as IP
  cameras serve it, read through OpenCV's FFmpeg backend: every frame comes
  out named URL#NNNNNN with the same lanes as the JPEG files it was made
  from; --max-frames stops early; lane-client streams such a URL through a
  real lane-server. Without an ffmpeg binary a Python server (standard
  library) serves the same stream;
* a GStreamer pipeline (videotestsrc ... ! appsink), when Debian's
  gstreamer1.0-plugins-base is installed;
* an unreachable URL: an error line, exit 1, no crash;
* --overlay-video of lane detect and lane-client stream, read back as video
  inputs (every frame there, at the camera's size);
* --fps and --realtime pace a replay (lower bounds on the elapsed time only).

Usage: live_input_test.py LANE LANE_SERVER LANE_CLIENT SOURCE_DIR
"""
import glob
import http.server
import json
import os
import socket
import subprocess
import sys
import tempfile
import shutil
import threading
import time

LANE, SERVER, CLIENT, SRC = sys.argv[1:5]
CONFIG = os.path.join(SRC, "configs", "synthetic.json")
failures = []


def check(condition, message):
    if not condition:
        failures.append(message)
        print("FAIL:", message, flush=True)


def run(args, timeout=120):
    return subprocess.run(args, capture_output=True, text=True, timeout=timeout)


def lines_of(stdout):
    return [json.loads(line) for line in stdout.splitlines() if line.strip()]


def serve_mjpeg(frames):
    """An MJPEG-over-HTTP server on a free loopback port; returns (server, url)."""

    class Handler(http.server.BaseHTTPRequestHandler):
        def do_GET(self):
            self.send_response(200)
            self.send_header("Content-Type", "multipart/x-mixed-replace; boundary=frame")
            self.end_headers()
            for data in frames:
                self.wfile.write(b"--frame\r\nContent-Type: image/jpeg\r\n"
                                 b"Content-Length: %d\r\n\r\n" % len(data))
                self.wfile.write(data)
                self.wfile.write(b"\r\n")

        def log_message(self, *args):
            pass

    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), Handler)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    return server, "http://127.0.0.1:%d/stream.mjpg" % server.server_address[1]


def wait_listening(port, timeout=10.0):
    """Waits until something listens on 127.0.0.1:port, without connecting
    (ffmpeg -listen 1 serves exactly one client)."""
    want = ":%04X" % port
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        with open("/proc/net/tcp") as f:
            for line in f.readlines()[1:]:
                fields = line.split()
                if fields[1].endswith(want) and fields[3] == "0A":
                    return True
        time.sleep(0.05)
    return False


def ffmpeg_mjpeg(frames_dir):
    """One client's MJPEG-over-HTTP stream of frames_dir/%06d.jpg, served by
    a local ffmpeg at 10 frames/s; returns (process, url)."""
    port = free_port()
    url = "http://127.0.0.1:%d/stream.mjpg" % port
    proc = subprocess.Popen(["ffmpeg", "-nostdin", "-loglevel", "error", "-re", "-framerate", "10",
                             "-i", os.path.join(frames_dir, "%06d.jpg"), "-c:v", "copy",
                             "-f", "mpjpeg", "-listen", "1", url],
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    check(wait_listening(port), "ffmpeg did not listen on %d" % port)
    return proc, url


FFMPEG = shutil.which("ffmpeg")


def live_url(frames_dir, python_url):
    """A fresh live URL: ffmpeg's when installed, else the Python server's."""
    if FFMPEG:
        proc, url = ffmpeg_mjpeg(frames_dir)
        servers.append(proc)
        return url
    return python_url


servers = []


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


with tempfile.TemporaryDirectory() as tmp:
    frames_dir = os.path.join(tmp, "frames")
    r = run([LANE, "render", "--config", CONFIG, "--count", "12", "--output", frames_dir,
             "--format", "jpg", "--num-lanes", "3"])
    check(r.returncode == 0, "lane render failed: " + r.stderr)
    files = sorted(glob.glob(os.path.join(frames_dir, "*.jpg")))
    jpegs = [open(f, "rb").read() for f in files]
    server, url = serve_mjpeg(jpegs)

    if not FFMPEG:
        print("note: no ffmpeg binary (Debian package ffmpeg): the Python server serves the streams")

    # --- MJPEG over HTTP through `lane detect`.
    url = live_url(frames_dir, url)
    r = run([LANE, "detect", "--config", CONFIG, "--seed", "7", url])
    check(r.returncode == 0, "lane detect URL: exit %d: %s" % (r.returncode, r.stderr[-500:]))
    live = lines_of(r.stdout)
    check(len(live) == len(jpegs), "lane detect URL: %d results for %d frames"
          % (len(live), len(jpegs)))
    check([x["frame"] for x in live] == ["%s#%06d" % (url, i) for i in range(len(live))],
          "lane detect URL: frame names %s" % [x["frame"] for x in live][:3])
    check(all("error" not in x and x["width"] == 640 for x in live), "lane detect URL: errors")
    r = run([LANE, "detect", "--config", CONFIG, "--seed", "7"] + files)
    files_out = lines_of(r.stdout)
    # The frames decode through FFmpeg's MJPEG decoder instead of libjpeg:
    # pixels differ by a grey level here and there, which changes what RANSAC
    # draws (control points move, a weak lane comes or goes, an extension
    # stops a step earlier). The lanes must still be the files' lanes: per
    # frame the count within one, and 80 % of the lanes run within 10 px (mean
    # horizontal distance over the image rows both cover, at least 20 rows)
    # of one of the file's.
    def polyline(lane, n=40):
        p = lane["image"]
        pts = []
        for i in range(n + 1):
            t = i / n
            w = [(1 - t) ** 3, 3 * t * (1 - t) ** 2, 3 * t * t * (1 - t), t ** 3]
            pts.append((sum(w[k] * p[k][0] for k in range(4)), sum(w[k] * p[k][1] for k in range(4))))
        return sorted(pts, key=lambda q: q[1])

    def x_at(pts, y):
        # Callers ask inside the polyline's row span; clamp so that a row
        # equal to an end point up to rounding still finds its segment.
        y = min(max(y, pts[0][1]), pts[-1][1])
        for (x0, y0), (x1, y1) in zip(pts, pts[1:]):
            if y0 <= y <= y1:
                return x0 if y1 == y0 else x0 + (x1 - x0) * (y - y0) / (y1 - y0)
        return pts[-1][0]

    def same_lane(a, b):
        pa, pb = polyline(a), polyline(b)
        lo, hi = max(pa[0][1], pb[0][1]), min(pa[-1][1], pb[-1][1])
        if hi - lo < 20:
            return False
        ys = [lo + (hi - lo) * k / 10 for k in range(11)]
        d = [abs(x_at(pa, y) - x_at(pb, y)) for y in ys]
        return sum(d) / len(d) < 10

    def near_lane(a, lanes):
        return any(same_lane(a, b) for b in lanes)

    counts_ok = all(abs(len(a["lanes"]) - len(b["lanes"])) <= 1 for a, b in zip(live, files_out))
    near = sum(near_lane(x, b["lanes"]) for a, b in zip(live, files_out) for x in a["lanes"])
    total = sum(len(a["lanes"]) for a in live)
    check(counts_ok and len(files_out) == len(live) and near >= 0.8 * total,
          "lane detect URL: %d of %d lanes near the files' (counts within one: %s)"
          % (near, total, counts_ok))
    check(sum(len(x["lanes"]) for x in live) >= 2 * len(live),
          "lane detect URL: too few lanes on 3-lane roads")

    r = run([LANE, "detect", "--config", CONFIG, "--max-frames", "5",
             live_url(frames_dir, url)])
    check(r.returncode == 0 and len(lines_of(r.stdout)) == 5,
          "--max-frames 5 on a live source: %d results" % len(lines_of(r.stdout)))

    # --- The same URL through lane-client and a real lane-server.
    port, metrics = free_port(), free_port()
    srv = subprocess.Popen([SERVER, "--address=127.0.0.1:%d" % port,
                            "--metrics_address=127.0.0.1:%d" % metrics, "--workers=2"],
                           stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    try:
        ok = False
        for _ in range(100):
            if run([CLIENT, "health", "--target", "127.0.0.1:%d" % port]).returncode == 0:
                ok = True
                break
            time.sleep(0.1)
        check(ok, "lane-server did not become healthy")
        r = run([CLIENT, "stream", "--target", "127.0.0.1:%d" % port, "--camera", "live",
                 "--config", CONFIG, live_url(frames_dir, url)])
        streamed = lines_of(r.stdout)
        check(r.returncode == 0, "lane-client stream URL: exit %d: %s"
              % (r.returncode, r.stderr[-500:]))
        check(len(streamed) == len(jpegs) and
              all(x.get("status", "OK") in ("OK", "FRAME_CODE_OK") and "error" not in x
                  for x in streamed),
              "lane-client stream URL: %d answers: %s" % (len(streamed), streamed[:1]))
        check(sum(len(x.get("lanes", [])) for x in streamed) >= 2 * len(jpegs),
              "lane-client stream URL: too few lanes")
        # --overlay-video from the stream, read back as a video input.
        avi = os.path.join(tmp, "stream-overlay.avi")
        r = run([CLIENT, "stream", "--target", "127.0.0.1:%d" % port, "--camera", "files",
                 "--config", CONFIG, "--overlay-video", avi] + files)
        back = lines_of(run([LANE, "detect", "--config", CONFIG, avi]).stdout)
        check(r.returncode == 0 and len(back) == len(files) and
              all(x.get("width") == 640 and "error" not in x for x in back),
              "lane-client --overlay-video: exit %d, %d frames read back" % (r.returncode, len(back)))
    finally:
        srv.terminate()
        srv.wait(timeout=30)
    server.shutdown()
    for proc in servers:  # an ffmpeg whose client left early (--max-frames)
        proc.kill()
        proc.wait(timeout=10)

    # --- lane detect --overlay-video, read back as a video input; a bad
    # extension is refused before any work.
    mp4 = os.path.join(tmp, "overlay.mp4")
    r = run([LANE, "detect", "--config", CONFIG, "--overlay-video", mp4, "-q"] + files)
    back = lines_of(run([LANE, "detect", "--config", CONFIG, mp4]).stdout)
    check(r.returncode == 0 and r.stderr == "" and len(back) == len(files) and
          back[-1]["frame"] == "overlay.mp4#%06d" % (len(files) - 1) and
          all(x.get("width") == 640 and "error" not in x for x in back),
          "lane detect --overlay-video: exit %d (%r), %d frames read back"
          % (r.returncode, r.stderr[-300:], len(back)))
    r = run([LANE, "detect", "--config", CONFIG, "--overlay-video", os.path.join(tmp, "x.gif")]
            + files[:1])
    check(r.returncode != 0 and "use a .mp4" in r.stderr, "--overlay-video x.gif: %r" % r.stderr)

    # --- A URL nobody serves: an error line, exit 1.
    dead = "http://127.0.0.1:%d/none.mjpg" % free_port()
    r = run([LANE, "detect", "--config", CONFIG, dead])
    out = lines_of(r.stdout)
    check(r.returncode == 1 and len(out) == 1 and "cannot open live source" in out[0].get("error", ""),
          "unreachable URL: exit %d, %s" % (r.returncode, out))

    # --- A GStreamer pipeline.
    plugin_dirs = glob.glob("/usr/lib/*/gstreamer-1.0/libgstvideotestsrc.so")
    if plugin_dirs:
        pipeline = "videotestsrc num-buffers=4 ! video/x-raw,width=640,height=480 ! videoconvert ! appsink"
        r = run([LANE, "detect", "--config", CONFIG, pipeline])
        out = lines_of(r.stdout)
        check(r.returncode == 0 and len(out) == 4 and out[0]["width"] == 640 and
              out[3]["frame"] == pipeline + "#000003",
              "GStreamer pipeline: exit %d, %s" % (r.returncode, [x.get("frame") for x in out]))
    else:
        print("SKIP part: GStreamer's videotestsrc is not installed (gstreamer1.0-plugins-base)")

    # --- Pacing: 12 frames at 20/s take at least 11/20 s; --realtime paces
    # image files at 30/s.
    for flags, rate in ((["--fps", "20"], 20.0), (["--realtime"], 30.0)):
        start = time.monotonic()
        r = run([LANE, "detect", "--config", CONFIG] + flags + files)
        elapsed = time.monotonic() - start
        check(r.returncode == 0 and len(lines_of(r.stdout)) == len(files), "%s: failed" % flags)
        check(elapsed >= (len(files) - 1) / rate * 0.95,
              "%s: %d frames in %.3f s, faster than %g/s" % (flags, len(files), elapsed, rate))

if failures:
    print("%d failure(s)" % len(failures))
    sys.exit(1)
print("live inputs: MJPEG over HTTP from %s (lane detect, lane-client + lane-server), "
      "--max-frames, " % ("ffmpeg" if FFMPEG else "a Python server") +
      "unreachable URL, GStreamer%s, --fps/--realtime pacing: PASS"
      % ("" if plugin_dirs else " (skipped)"))
