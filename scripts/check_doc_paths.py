#!/usr/bin/env python3
"""Fails when a document or a source comment names a file that does not exist.

    scripts/check_doc_paths.py [--verbose]

Reads README.md, every other Markdown file in the repository, and the
comments of the C++, proto, CMake, Python and shell files (whole-line ones
for the last two), and checks what they name:

* include paths, `lane/geometry/camera.h`, against every include root
  (core/*/include, decode/include, eval/include, synthetic/include, and the
  repository root for `wire/...` and `io/...`); `lane/v1/*.pb.h` against
  proto/lane/v1/*.proto;
* repository paths, `server/frame_stream.cc`, `docs/`, `wire/x.{h,cc}`,
  `client/bench*.cc`: relative to the repository root or to the naming
  file's folder, braces expanded and globs matched; a path with a source
  extension is checked whatever its first folder, so a renamed folder leaves
  its old paths failing; `build/DIR/NAME` must name an existing DIR;
* bare source file names, `frame_stream.cc`: some file of that name;
* Markdown links, relative to the document's folder, and their #anchors
  against the target's headings (GitHub's slugs);
* sections named after a document, `service.md, "Live view"` or
  `README.md ("Bad input")`: a heading of that document;
* GoogleTest names in a document, `ResumeTest.AStateBelongsToItsCamera` or
  `AuthTest.*`: a TEST, TEST_F or TEST_P of that suite and name.

Paths outside the repository (/etc/..., ../shared/..., URLs), placeholders
(DIR/..., <build>/...), run outputs (out/...) and paths a command line in
the same document writes (`--output PATH`) are not checked. Exit status 1
and one line per problem when anything is missing.
"""
import fnmatch
import os
import re
import subprocess
import sys

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), ".."))

# Extensions of files whose names are checked even without a known folder.
SOURCE_EXT = ("h", "cc", "py", "proto", "md", "sh", "cmake", "yaml", "yml", "json", "txt",
              "template", "service", "conf", "in")
# Extensions a target-like path may stand for (fuzz/config_fuzzer -> .cc).
TARGET_EXT = (".cc", ".py", ".sh")
# Names that look like repository paths but are something else.
NOT_PATHS = {
    "core/imgproc/imgcodecs",  # OpenCV's modules
    "deploy/lane-server",  # a kubectl resource (kubectl rollout status deploy/lane-server)
    "deployment/lane-server",
    "configs/cam07.json",  # lane backfill's example manifest
    "configs/cam12.json",
    "configs/cam7.json",
}
# Files outside the repository that comments name.
SYSTEM_FILES = {"jpeglib.h", "jerror.h", "png.h", "zlib.h"}
# First path components of things that are not in the repository.
EXTERNAL_PREFIXES = ("absl/", "grpc/", "grpcpp/", "google/", "opencv2/", "gtest/", "gmock/",
                     "benchmark/", "prometheus/", "nlohmann/", "Eigen/", "CLI/", "sys/",
                     "linux/", "lib/", "bin/", "share/", "include/", "etc/", "usr/",
                     "tmp/", "out/", "../shared/", "shared/", "~", "$", "-", "lanedet/",
                     "lanedet_", "python3/", "dist-packages/", "site-packages/")
GENERATED = re.compile(r"(\.pb\.h|\.pb\.cc|_pb2(_grpc)?\.py)$")


def repo_files():
    try:
        out = subprocess.check_output(["git", "ls-files", "--cached", "--others",
                                       "--exclude-standard"], cwd=ROOT,
                                      stderr=subprocess.DEVNULL)
        files = [f for f in out.decode().split("\n") if f]
        return [f for f in files if os.path.exists(os.path.join(ROOT, f))]
    except (OSError, subprocess.CalledProcessError):
        files = []
        for d, subdirs, names in os.walk(ROOT):
            rel = os.path.relpath(d, ROOT)
            subdirs[:] = [s for s in subdirs
                          if not s.startswith((".", "build", "out")) or rel != "."]
            files += [os.path.normpath(os.path.join(rel, n)) for n in names]
        return files


FILES = repo_files()
FILE_SET = set(FILES)
DIR_SET = {os.path.dirname(f) for f in FILES}
for _d in list(DIR_SET):
    while _d:
        _d = os.path.dirname(_d)
        DIR_SET.add(_d)
BASENAMES = {os.path.basename(f) for f in FILES}
TOP = {f.split("/")[0] for f in FILES if "/" in f}
# Every folder named include, at any depth, and the repository's root (for
# wire/... and io/...).
INCLUDE_ROOTS = sorted({("/" + d)[1:("/" + d + "/").index("/include/") + len("/include")]
                        for d in DIR_SET if "/include/" in "/" + d + "/"} | {""})


def exists(rel):
    rel = os.path.normpath(rel)
    if rel == ".":
        return True
    if any(c in rel for c in "*?["):
        return any(fnmatch.fnmatch(f, rel) for f in FILES) or any(
            fnmatch.fnmatch(d, rel) for d in DIR_SET)
    return rel in FILE_SET or rel in DIR_SET


def expand_braces(path):
    m = re.search(r"\{([^{}]*)\}", path)
    if not m:
        return [path]
    out = []
    for alt in m.group(1).split(","):
        out += expand_braces(path[:m.start()] + alt + path[m.end():])
    return out


def include_exists(path):
    if GENERATED.search(path) and path.startswith("lane/v1/"):
        stem = re.sub(r"\.(grpc\.)?pb\.(h|cc)$", "", path)
        return exists("proto/" + stem + ".proto")
    return any(exists(os.path.join(r, path)) for r in INCLUDE_ROOTS)


def ignored(path):
    """True when git ignores PATH: a build or run output."""
    try:
        return subprocess.call(["git", "check-ignore", "-q", "--no-index", path], cwd=ROOT,
                               stderr=subprocess.DEVNULL) == 0
    except OSError:
        return False


def is_target(rel):
    """True when REL is DIR/NAME with NAME a target of DIR/CMakeLists.txt: a
    program in the build tree (server/lane-server, tests/core/core_test)."""
    folder, name = os.path.split(rel)
    cmake = os.path.join(folder, "CMakeLists.txt")
    if cmake not in FILE_SET:
        return False
    text = open(os.path.join(ROOT, cmake), encoding="utf-8").read()
    return re.search(r"(add_executable|lane_add_test|add_library)\(\s*" + re.escape(name) + r"\b",
                     text) is not None


def path_exists(path, folder):
    """True when PATH names something in the repository, seen from FOLDER."""
    for p in expand_braces(path):
        p = re.sub(r"<[^<>]*>", "*", p)
        p = p.rstrip("/") or "/"
        if p.startswith("./"):
            p = p[2:]
        candidates = [p, os.path.join(folder, p)]
        if not any(exists(c) or any(exists(c + e) for e in TARGET_EXT) or is_target(c)
                   for c in candidates):
            return False
    return True


def slug(heading):
    text = re.sub(r"\[([^\]]*)\]\([^)]*\)", r"\1", heading).strip().lower()
    text = re.sub(r"[^\w\- ]", "", text)
    return text.replace(" ", "-")


HEADING_CACHE = {}


def headings(rel):
    if rel not in HEADING_CACHE:
        titles, slugs, seen = [], set(), {}
        fence = False
        for line in open(os.path.join(ROOT, rel), encoding="utf-8").read().split("\n"):
            if line.startswith("```"):
                fence = not fence
            if fence:
                continue
            m = re.match(r"#{1,6}\s+(.*?)\s*#*\s*$", line)
            if m:
                s = slug(m.group(1))
                n = seen.get(s, 0)
                seen[s] = n + 1
                slugs.add(s if n == 0 else "%s-%d" % (s, n))
                titles.append(m.group(1).replace("`", "").lower())
            # A paragraph's bold lead-in is a section too (no anchor).
            m = re.match(r"(?:[*-] )?\*\*(.+?)\*\*", line)
            if m:
                titles.append(m.group(1).replace("`", "").lower())
        HEADING_CACHE[rel] = (titles, slugs)
    return HEADING_CACHE[rel]


def resolve_doc(name, folder):
    """The repository path of the Markdown file NAME mentioned from FOLDER."""
    for c in (os.path.normpath(os.path.join(folder, name)), os.path.normpath(name),
              "docs/" + name):
        if c in FILE_SET:
            return c
    return None


PATH_TOKEN = re.compile(r"(?<![\w./@:$-])((?:\.{1,2}/)?[\w.*{}<>,+-]*[\w*}>]/[\w.*{}<>,/+-]*)")
BARE_FILE = re.compile(r"(?<![\w./@:<*-])([A-Za-z_][\w-]*\.(?:h|cc|proto|py|sh|cmake))\b(?![/\w(-])")
INCLUDE_PATH = re.compile(r"(?<![\w/.-])(lane/[\w/]+\.h)\b")
MD_LINK = re.compile(r"\]\(([^)\s]+)\)")
SECTION_REF = re.compile(
    r"([\w./-]*(?:README|[\w-]+\.md))(?:\]\([^)]*\))?(?:'s)?\)?,?\s*(?:section\s*)?\(?\"([^\"]{2,80})\"")
OUTPUT_FLAG = re.compile(r"(?:--output[= ]|-o |>\s*|--overlay[= ])(\S+)")


TEST_DEF = re.compile(r"\b(?:TEST|TEST_F|TEST_P|TYPED_TEST)\(\s*(\w+)\s*,\s*(\w+)\s*\)")
TEST_REF = re.compile(r"`(\w+Test)\.(\w+|\*)`")
TESTS = None


def gtest_names():
    global TESTS
    if TESTS is None:
        TESTS = set()
        for f in FILES:
            if f.endswith(".cc") and ("test" in f or f.startswith("tests/")):
                text = open(os.path.join(ROOT, f), encoding="utf-8", errors="replace").read()
                for m in TEST_DEF.finditer(text):
                    TESTS.add((m.group(1), m.group(2)))
                    TESTS.add((m.group(1), "*"))
    return TESTS


def check_text(rel, text, problems, is_doc):
    """Checks TEXT, found in file REL (a document or a file's comments)."""
    folder = os.path.dirname(rel)
    written = set(m.group(1).strip("`'\"") for m in OUTPUT_FLAG.finditer(text))
    for lineno, line in enumerate(text.split("\n"), 1):
        where = "%s:%d" % (rel, lineno)
        spans = []
        if is_doc:
            for m in MD_LINK.finditer(line):
                target = m.group(1)
                spans.append(m.span(1))
                if re.match(r"[a-z]+:", target):
                    continue
                path, _, anchor = target.partition("#")
                if path:
                    dest = os.path.normpath(os.path.join(folder, path))
                    if not exists(dest):
                        problems.append("%s: link to %s: no such file (from %s)" % (where, target,
                                                                                 folder or "."))
                        continue
                else:
                    dest = rel
                if anchor and dest.endswith(".md") and anchor not in headings(dest)[1]:
                    problems.append("%s: link to %s: %s has no heading #%s" % (where, target, dest,
                                                                           anchor))
        for m in SECTION_REF.finditer(line):
            name = m.group(1)
            name = name if name.endswith(".md") else name + ".md"
            doc = resolve_doc(os.path.basename(name) if "/" not in name else name, folder)
            if doc is None:
                doc = resolve_doc(name, folder)
            if doc is None:
                continue  # the path check reports it
            section = m.group(2).replace("`", "").lower()
            if not any(section in t for t in headings(doc)[0]):
                problems.append("%s: %s has no section \"%s\"" % (where, doc, m.group(2)))
        for m in TEST_REF.finditer(line) if is_doc else ():
            if (m.group(1), m.group(2)) not in gtest_names():
                problems.append("%s: %s.%s: no such test" % (where, m.group(1), m.group(2)))
        for m in INCLUDE_PATH.finditer(line):
            if not include_exists(m.group(1)):
                problems.append("%s: include path %s: in no include root" % (where, m.group(1)))
        for m in PATH_TOKEN.finditer(line):
            if any(a <= m.start(1) < b for a, b in spans):
                continue
            token = m.group(1).rstrip(".,;:")
            token = re.sub(r":\d+$", "", token)
            token = re.sub(r"#.*$", "", token)
            if check_path_token(token, folder, written) is False:
                problems.append("%s: %s: no such file or folder" % (where, token))
        for m in BARE_FILE.finditer(line):
            name = m.group(1)
            if (name not in BASENAMES and name + ".in" not in BASENAMES and name not in SYSTEM_FILES
                    and not GENERATED.search(name) and not name.startswith(("my_", "my-"))
                    and name not in written):
                problems.append("%s: %s: no file of that name" % (where, name))


def check_path_token(token, folder, written):
    """False when TOKEN names a repository path that is missing, else True or None."""
    if (token in NOT_PATHS or token in written or "://" in token or token.startswith("/")
            or "..." in token):
        return None
    # An installed layout's include/, lib/ ...; checked once the repository
    # has such a folder itself.
    if token.startswith(EXTERNAL_PREFIXES) and token.split("/")[0] not in TOP:
        return None
    if token.startswith("lane/") and token.endswith(".h"):
        return None  # the include check
    parts = token.strip("/").split("/")
    if any(re.match(r"[A-Z][A-Z0-9_-]+(\.\w+)?$", c) and c not in BASENAMES for c in parts) or any(
            c.startswith(("my_", "my-", "<")) for c in parts):
        return None  # placeholders: DIR/x.json, io/NAME.h, configs/my-camera.json
    if GENERATED.search(token):
        return None
    first = token.split("/")[0]
    if re.match(r"build[\w-]*$", first):
        rest = token.split("/")[1:]
        if len(rest) < 2 or any(c in "".join(rest) for c in "<*{"):
            return None
        return exists("/".join(rest[:-1])) and (
            is_target("/".join(rest)) or exists("/".join(rest)) or "." in rest[-1])
    if first.startswith("."):
        first = token.lstrip("./").split("/")[0]
    last = token.rstrip("/").split("/")[-1]
    ext = last.rsplit(".", 1)[1] if "." in last else ""
    if (first in TOP or (token.startswith("../") and not token.startswith("../shared"))
            or ext in SOURCE_EXT):
        return path_exists(token, folder) or ignored(token)
    return None


def comments(path, text):
    """The comments of a source file, other lines blanked (line numbers kept)."""
    if path.endswith(("CMakeLists.txt", ".cmake")):
        return "\n".join(re.sub(r"^[^#]*#?", "", l) if "#" in l else "" for l in text.split("\n"))
    if path.endswith((".py", ".sh")):  # whole-line comments only
        return "\n".join(l if l.lstrip().startswith("#") and not l.startswith("#!") else ""
                         for l in text.split("\n"))
    keep, last = [], 0
    for m in CXX_TOKENS.finditer(text):
        keep.append(BLANK.sub(" ", text[last:m.start()]))
        token = m.group(0)
        keep.append(token if token.startswith("/") else BLANK.sub(" ", token))
        last = m.end()
    keep.append(BLANK.sub(" ", text[last:]))
    return "".join(keep)


# Comments (kept) and the literals that may hold comment-like text (blanked).
CXX_TOKENS = re.compile(
    r"""//[^\n]*|/\*.*?(?:\*/|\Z)"""
    r"""|(?<![\w])(?:u8|u|U|L)?R"([^(\s"]{0,16})\(.*?(?:\)\1"|\Z)"""
    r"""|"(?:\\.|[^"\\\n])*"?|(?<![0-9A-Za-z_])'(?:\\.|[^'\\\n])*'?""",
    re.S)
BLANK = re.compile(r"[^\n]")


def main():
    verbose = "--verbose" in sys.argv
    problems = []
    docs = [f for f in FILES if f.endswith(".md")]
    sources = [f for f in FILES if f.endswith((".h", ".cc", ".proto", "CMakeLists.txt", ".cmake",
                                               ".py", ".sh"))]
    for rel in docs:
        check_text(rel, open(os.path.join(ROOT, rel), encoding="utf-8").read(), problems, True)
    for rel in sources:
        text = open(os.path.join(ROOT, rel), encoding="utf-8", errors="replace").read()
        check_text(rel, comments(rel, text), problems, False)
    for p in problems:
        print(p)
    if verbose or problems:
        print("%d documents and %d sources checked, %d problems" % (len(docs), len(sources),
                                                                   len(problems)))
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
