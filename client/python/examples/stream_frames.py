#!/usr/bin/env python3
"""Streams a folder of JPEG/PNG frames, or a video through OpenCV, to lane-server
and prints one JSON line per frame: frame id, status and the lanes' image
control points.

    export PYTHONPATH=$PWD/client/python
    python3 client/python/examples/stream_frames.py --target 127.0.0.1:50051 \\
        --camera cam0 --config configs/synthetic.json frames/
    python3 client/python/examples/stream_frames.py --camera cam0 \\
        --config configs/caltech.json drive.mp4          # needs python3-opencv

A folder's files are sent as they are (encoded); video frames are sent raw
(BGR arrays from cv2.VideoCapture). The stream reconnects on its own when the
server restarts.
"""

import argparse
import json
import os
import sys

from lane_client import LaneClient, load_stubs


def folder_frames(folder):
    for name in sorted(os.listdir(folder)):
        if name.lower().endswith((".jpg", ".jpeg", ".png")):
            with open(os.path.join(folder, name), "rb") as f:
                yield f.read()


def video_frames(path):
    import cv2  # python3-opencv, only for videos and cameras

    capture = cv2.VideoCapture(path)
    if not capture.isOpened():
        raise SystemExit(f"cannot open {path}")
    try:
        while True:
            ok, frame = capture.read()  # H x W x 3 uint8, BGR
            if not ok:
                return
            yield frame
    finally:
        capture.release()


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("input", help="folder of JPEG/PNG frames, or a video file / URL")
    parser.add_argument("--target", default="127.0.0.1:50051")
    parser.add_argument("--camera", default="default")
    parser.add_argument("--config", help="configs/*.json: create or confirm the session")
    parser.add_argument("--ca", help="PEM CA file: TLS")
    parser.add_argument("--window", type=int, default=8, help="frames in flight")
    args = parser.parse_args()

    pb2, _ = load_stubs()
    frames = folder_frames(args.input) if os.path.isdir(args.input) else video_frames(args.input)
    with LaneClient(args.target, ca=args.ca) as client:
        for response in client.stream(args.camera, frames, config=args.config,
                                      window=args.window):
            print(json.dumps({
                "frame_id": response.frame_id,
                "status": pb2.FrameCode.Name(response.status.code),
                "message": response.status.message,
                "lanes": [[[p.x, p.y] for p in lane.image.control_points]
                          for lane in response.lanes],
            }))
    return 0


if __name__ == "__main__":
    sys.exit(main())
