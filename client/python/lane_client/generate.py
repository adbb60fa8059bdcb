"""Generates the Python modules of proto/lane/v1/lane_service.proto.

    python3 -m lane_client.generate [--out DIR] [--proto-dir DIR]

It runs Debian's `protoc` (package protobuf-compiler) with its
`grpc_python_plugin` (package protobuf-compiler-grpc). Debian's
python3-grpc-tools (1.14) cannot be used: it does not know proto3 `optional`,
which the API uses throughout.

The modules are written to DIR/lane/v1/lane_service_pb2.py (messages),
lane_service_pb2_grpc.py (the stub) and lane_service_pb2.pyi (type hints),
with DIR/lane_client_stubs.json recording the proto's SHA-256, so that
lane_client can warn when the proto changed after generation.

DIR defaults to lane_client/_generated/ inside this package, where
lane_client looks first; a DIR elsewhere is found through the environment
variable LANE_CLIENT_STUBS=DIR. The proto is looked for in --proto-dir, then
$LANE_PROTO_DIR, then proto/ of the checkout this package sits in.

This file imports nothing of lane_client, so the build can run it as a plain
script (tests/python/CMakeLists.txt does).
"""

import argparse
import hashlib
import json
import os
import shutil
import subprocess
import sys
import tempfile

PROTO_FILE = "lane/v1/lane_service.proto"
GENERATED = ("lane_service_pb2.py", "lane_service_pb2_grpc.py", "lane_service_pb2.pyi")
STAMP_FILE = "lane_client_stubs.json"

_PACKAGE_DIR = os.path.dirname(os.path.abspath(__file__))


def default_out_dir():
    """lane_client/_generated/: the directory lane_client searches first."""
    return os.path.join(_PACKAGE_DIR, "_generated")


def default_proto_dir():
    """$LANE_PROTO_DIR, else proto/ of the checkout (client/python/lane_client/../../../proto)."""
    env = os.environ.get("LANE_PROTO_DIR")
    if env:
        return env
    return os.path.normpath(os.path.join(_PACKAGE_DIR, "..", "..", "..", "proto"))


def proto_digest(proto_dir):
    """SHA-256 of lane_service.proto, hex; None when the file is not there."""
    path = os.path.join(proto_dir, PROTO_FILE)
    try:
        with open(path, "rb") as f:
            return hashlib.sha256(f.read()).hexdigest()
    except OSError:
        return None


class GenerateError(RuntimeError):
    """The stubs could not be generated (missing tool or proto, protoc failed)."""


def _find_tool(explicit, env_name, name, package):
    tool = explicit or os.environ.get(env_name) or shutil.which(name)
    if not tool:
        raise GenerateError(
            f"{name} not found: install Debian's {package} "
            f"(apt-get install {package}), or set {env_name}")
    return tool


def generate(out_dir=None, proto_dir=None, protoc=None, plugin=None):
    """Writes the modules into out_dir and returns out_dir.

    The files are written to a temporary directory first and then moved into
    place one by one (os.replace), so a concurrent import never sees a
    half-written module.
    """
    out_dir = os.path.abspath(out_dir or default_out_dir())
    proto_dir = os.path.abspath(proto_dir or default_proto_dir())
    proto_path = os.path.join(proto_dir, PROTO_FILE)
    if not os.path.isfile(proto_path):
        raise GenerateError(
            f"{proto_path} not found: pass --proto-dir (the folder that holds "
            f"{PROTO_FILE}) or set LANE_PROTO_DIR")
    protoc = _find_tool(protoc, "LANE_PROTOC", "protoc", "protobuf-compiler")
    plugin = _find_tool(plugin, "LANE_GRPC_PYTHON_PLUGIN", "grpc_python_plugin",
                        "protobuf-compiler-grpc")

    os.makedirs(out_dir, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix=".lane_stubs_", dir=out_dir) as tmp:
        command = [
            protoc, f"-I{proto_dir}", f"--python_out={tmp}", f"--pyi_out={tmp}",
            f"--grpc_out={tmp}", f"--plugin=protoc-gen-grpc={plugin}", proto_path,
        ]
        done = subprocess.run(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                              universal_newlines=True, check=False)
        if done.returncode != 0:
            raise GenerateError(f"{' '.join(command)} failed (exit {done.returncode}):\n"
                                f"{done.stderr.strip()}")
        target = os.path.join(out_dir, "lane", "v1")
        os.makedirs(target, exist_ok=True)
        for name in GENERATED:
            os.replace(os.path.join(tmp, "lane", "v1", name), os.path.join(target, name))
        stamp = {"proto": PROTO_FILE, "proto_sha256": proto_digest(proto_dir),
                 "protoc": protoc, "grpc_python_plugin": plugin}
        stamp_tmp = os.path.join(tmp, STAMP_FILE)
        with open(stamp_tmp, "w") as f:
            json.dump(stamp, f, indent=2)
            f.write("\n")
        os.replace(stamp_tmp, os.path.join(out_dir, STAMP_FILE))
    return out_dir


def main(argv=None):
    parser = argparse.ArgumentParser(
        prog="python3 -m lane_client.generate",
        description="Generate the Python gRPC stubs of lane.v1 with protoc and grpc_python_plugin.")
    parser.add_argument("--out", help=f"output directory (default: {default_out_dir()}); "
                        "set LANE_CLIENT_STUBS to it when it is not the default")
    parser.add_argument("--proto-dir", help=f"folder holding {PROTO_FILE} "
                        f"(default: $LANE_PROTO_DIR or {default_proto_dir()})")
    parser.add_argument("--protoc", help="protoc binary (default: $LANE_PROTOC or protoc on PATH)")
    parser.add_argument("--plugin", help="grpc_python_plugin binary (default: "
                        "$LANE_GRPC_PYTHON_PLUGIN or grpc_python_plugin on PATH)")
    parser.add_argument("--quiet", action="store_true", help="print nothing on success")
    args = parser.parse_args(argv)
    try:
        out = generate(args.out, args.proto_dir, args.protoc, args.plugin)
    except GenerateError as e:
        print(f"lane_client.generate: {e}", file=sys.stderr)
        return 1
    if not args.quiet:
        print(f"lane_client.generate: stubs written to {out}")
        if os.path.abspath(out) != os.path.abspath(default_out_dir()):
            print(f"  use them with: export LANE_CLIENT_STUBS={out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
