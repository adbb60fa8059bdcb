#!/usr/bin/env python3
"""A viewer of lane-server's live view for the bench (bench/live-view-bench.sh).

  live_viewer.py PORT CAMERA SECONDS page     asks as the camera page does:
      its data every second, the frame picture every 1/5 s (only a newer one,
      ?after=SEQ) and the top view with each new picture
  live_viewer.py PORT CAMERA SECONDS stalled  a viewer that reads nothing:
      every second it opens a connection with a 1 KiB receive buffer, asks
      for the camera's frame picture (which keeps the camera watched and
      drawn) and never reads the answer; the connections stay open

Waits until the camera has a session (the bench creates it), then runs for
SECONDS. Prints what it got on stdout. Only 127.0.0.1.
"""
import http.client
import json
import socket
import sys
import time
import urllib.parse


def get(port, path):
    c = http.client.HTTPConnection("127.0.0.1", port, timeout=10)
    c.request("GET", path)
    r = c.getresponse()
    body = r.read()
    headers = dict(r.getheaders())
    c.close()
    return r.status, headers, body


def wait_for_camera(port, camera, viewer, deadline):
    while time.monotonic() < deadline:
        try:
            status, _, body = get(port, "/api/sessions?viewer=" + viewer)
            if status == 200 and any(s["camera_id"] == camera
                                     for s in json.loads(body)["sessions"]):
                return True
        except OSError:
            pass
        time.sleep(0.2)
    return False


def page(port, camera, viewer, seconds):
    path = "/cameras/" + urllib.parse.quote(camera, safe="")
    get(port, path + "?viewer=" + viewer)
    end = time.monotonic() + seconds
    next_data = 0.0
    seq = 0
    pictures = 0
    while time.monotonic() < end:
        now = time.monotonic()
        if now >= next_data:
            get(port, "/api" + path + "?viewer=" + viewer)
            next_data = now + 1.0
        status, headers, _ = get(port, path + "/frame.jpg?viewer=%s&after=%d" % (viewer, seq))
        if status == 200:
            seq = int(headers.get("X-Picture-Seq", seq))
            get(port, path + "/top.jpg?viewer=%s&seq=%d" % (viewer, seq))
            pictures += 1
        time.sleep(0.2)
    print("page viewer: %d pictures in %.0f s" % (pictures, seconds))


def stalled(port, camera, viewer, seconds):
    path = "/cameras/" + urllib.parse.quote(camera, safe="") + "/frame.jpg?viewer=" + viewer
    sockets = []
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        s = socket.socket()
        s.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 1024)
        s.connect(("127.0.0.1", port))
        s.sendall(("GET %s HTTP/1.0\r\nHost: 127.0.0.1\r\n\r\n" % path).encode())
        sockets.append(s)  # never read
        time.sleep(1.0)
    print("stalled viewer: %d requests never read" % len(sockets))
    for s in sockets:
        s.close()


def main():
    port, camera, seconds, mode = int(sys.argv[1]), sys.argv[2], float(sys.argv[3]), sys.argv[4]
    # One viewer: the lease of its first request, renewed by every other.
    viewer = ""
    deadline = time.monotonic() + 30
    while not viewer and time.monotonic() < deadline:
        try:
            viewer = get(port, "/")[1].get("X-Viewer", "")
        except OSError:
            time.sleep(0.2)
    if not viewer or not wait_for_camera(port, camera, viewer, deadline):
        print("no session %s" % camera, file=sys.stderr)
        return 1
    (page if mode == "page" else stalled)(port, camera, viewer, seconds)
    return 0


if __name__ == "__main__":
    sys.exit(main())
