"""Build steps pyproject.toml cannot say: the version from the project's
VERSION file, and the gRPC stubs generated into the built package.

The proto and VERSION are read from the checkout this folder sits in
(client/python/../../proto), or from $LANE_PROTO_DIR and $LANE_VERSION_FILE.
Debian's protoc (protobuf-compiler) and grpc_python_plugin
(protobuf-compiler-grpc) generate the stubs: see lane_client/generate.py.
"""

import importlib.util
import os

from setuptools import setup
from setuptools.command.build_py import build_py

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.normpath(os.path.join(HERE, "..", ".."))


def _generate_module():
    # generate.py imports nothing of lane_client: loaded as a plain file.
    spec = importlib.util.spec_from_file_location(
        "lane_client_generate", os.path.join(HERE, "lane_client", "generate.py"))
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _version():
    path = os.environ.get("LANE_VERSION_FILE") or os.path.join(ROOT, "VERSION")
    try:
        with open(path, encoding="utf-8") as f:
            return f.readline().strip()
    except OSError as e:
        raise SystemExit(f"lane-client: cannot read the project's version from {path}: "
                         f"{e.strerror} (set LANE_VERSION_FILE)") from e


class BuildWithStubs(build_py):
    """build_py, then the stubs into BUILD_LIB/lane_client/_generated/."""

    def run(self):
        super().run()
        generate = _generate_module()
        out = os.path.join(self.build_lib, "lane_client", "_generated")
        proto_dir = os.environ.get("LANE_PROTO_DIR") or os.path.join(ROOT, "proto")
        try:
            generate.generate(out_dir=out, proto_dir=proto_dir)
        except generate.GenerateError as e:
            raise SystemExit(f"lane-client: generating the gRPC stubs failed: {e}") from e
        # The version, for lane_client.__version__ outside an installed
        # distribution's metadata (an egg-info-less build tree).
        with open(os.path.join(self.build_lib, "lane_client", "_version.py"), "w",
                  encoding="utf-8") as f:
            f.write(f'__version__ = "{_version()}"\n')


setup(version=_version(), cmdclass={"build_py": BuildWithStubs})
