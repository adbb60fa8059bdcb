#!/usr/bin/env python3
"""Functions longer than LINES lines (default 80), and files longer than 600.

    scripts/long_functions.py [LINES]       list them
    scripts/long_functions.py --check       fail (exit 1) beyond the limits

The limits (issues 33 and 48): at most 5 functions over 80 lines in the
whole tree, tests included, each with its reason in the code; no C++ or
Python source over 600 lines, tests included.

A function runs from the first line of its declaration (its template line,
if any) to its closing brace. C++: every body at namespace or class scope
is found, whatever its form: free functions, members defined in or out of
their class, constructors and destructors (with initializer lists, braced
or not), operators, conversion functions, functions with trailing return
types or attributes, test bodies (TEST(...), TEST_F(...)) and lambdas held
by a variable at namespace scope; a lambda or local class inside a function
counts towards that function. Comments, strings and preprocessor lines are
blanked first. Python: every function and method, by the ast module, with
its decorators; a nested function counts towards the one around it.
"""
import ast
import os
import re
import subprocess
import sys

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), ".."))
MAX_LONG_FUNCTIONS = 5
MAX_FILE_LINES = 600
CXX_EXT = (".cc", ".h", ".cpp", ".hpp")


def source_files():
    try:
        out = subprocess.check_output(["git", "ls-files", "--cached", "--others",
                                       "--exclude-standard"], cwd=ROOT,
                                      stderr=subprocess.DEVNULL).decode()
        files = [f for f in out.split("\n") if f]
    except (OSError, subprocess.CalledProcessError):
        files = []
        for d, subdirs, names in os.walk(ROOT):
            if d == ROOT:
                subdirs[:] = [s for s in subdirs if not s.startswith((".", "build", "out"))]
            files += [os.path.relpath(os.path.join(d, n), ROOT) for n in names]
    return sorted(f for f in files if f.endswith(CXX_EXT + (".py",))
                  and os.path.isfile(os.path.join(ROOT, f)))


# What blank_cxx replaces: preprocessor lines (with their continuations),
# comments, raw strings, string literals and character literals (a ' after a
# digit or letter is a digit separator, 1'000, and is left alone).
BLANKED = re.compile(
    r"""^[ \t]*\#(?:[^\n]*\\\n)*[^\n]*"""
    r"""|//[^\n]*"""
    r"""|/\*.*?(?:\*/|\Z)"""
    r"""|(?<![\w])(?:u8|u|U|L)?R"([^(\s"]{0,16})\(.*?(?:\)\1"|\Z)"""
    r"""|"(?:\\.|[^"\\\n])*"?"""
    r"""|(?<![0-9A-Za-z_])'(?:\\.|[^'\\\n])*'?""",
    re.M | re.S)


def blank_cxx(text):
    """TEXT with comments, string and character literals and preprocessor
    lines replaced by spaces; newlines kept, so offsets map to lines."""
    return BLANKED.sub(lambda m: re.sub(r"[^\n]", " ", m.group(0)), text)


def top_level(text):
    """TEXT with everything inside (), [] and <> of templates blanked, so
    only the top level's tokens are left ('(' and ')' themselves stay)."""
    out, depth = [], 0
    for c in text:
        if c in "([":
            out.append(c if depth == 0 else " ")
            depth += 1
        elif c in ")]":
            depth = max(depth - 1, 0)
            out.append(c if depth == 0 else " ")
        else:
            out.append(c if depth == 0 else " ")
    return "".join(out)


TEMPLATE = re.compile(r"^\s*template\s*<")
ACCESS = re.compile(r"^\s*(public|private|protected)\s*:(?!:)")
LAMBDA = re.compile(r"^\s*\[[^\]]*\]\s*(\([^)]*\))?\s*[\w\s]*(->[^{]*)?$", re.S)


def strip_prefixes(header):
    while True:
        m = ACCESS.match(header)
        if m:
            header = header[m.end():]
            continue
        m = TEMPLATE.match(header)
        if m:
            depth, k = 1, m.end()
            while k < len(header) and depth:
                depth += {"<": 1, ">": -1}.get(header[k], 0)
                k += 1
            header = header[k:]
            continue
        return header


def classify(header):
    """What a '{' after HEADER (at namespace or class scope) opens:
    'scope' (namespace, class), 'function', 'member-init' (a braced member
    initializer inside a constructor's initializer list) or 'data'."""
    h = strip_prefixes(header).strip()
    words = h.split()
    if not words:
        return "data"
    if words[0] in ("namespace", "extern") or words[:2] == ["inline", "namespace"]:
        return "scope"
    if words[0] in ("class", "struct", "union") or (words[0] == "typedef" and len(words) > 1 and
                                                    words[1] in ("class", "struct", "union")):
        return "scope"
    if words[0] == "enum" or words[:2] == ["typedef", "enum"]:
        return "data"
    flat = top_level(h)
    paren = flat.find("(")
    eq = re.search(r"(?<![=!<>])=(?!=)", flat)
    if eq and (paren < 0 or eq.start() < paren) and "operator" not in flat[:eq.start()]:
        return "function" if LAMBDA.match(h[eq.end():]) else "data"
    if paren < 0:
        return "data"
    # A constructor's initializer list: a ':' after the parameters.
    after = flat[flat.find(")", paren) + 1:] if ")" in flat[paren:] else ""
    if re.search(r"(?<!:):(?!:)", after):
        last = h.rstrip()[-1:]
        return "member-init" if (last.isalnum() or last in "_>") else "function"
    return "function"


def function_name(header):
    h = strip_prefixes(header)
    flat = top_level(h)
    eq = re.search(r"(?<![=!<>])=(?!=)", flat)
    paren = flat.find("(")
    if eq and (paren < 0 or eq.start() < paren):  # a lambda: its variable
        m = re.search(r"([\w:]+)\s*$", h[:eq.start()])
        return (m.group(1) if m else "lambda") + " (lambda)"
    m = re.search(r"((?:[\w~]+::)*(?:operator\s*(?:\(\)|[^\s(]+)|~?\w+))\s*$", flat[:paren])
    name = m.group(1) if m else h.strip().split("\n")[0]
    if re.match(r"[A-Z_0-9]+$", name):  # TEST(Suite, Name) and the like
        close = h.find(")", h.find("("))
        return re.sub(r"\s+", " ", h[h.find(name):close + 1])
    return name


def cxx_functions(text):
    """(first line, last line, name) of every function body in TEXT."""
    code = blank_cxx(text)
    found = []
    # Each open brace: (kind, header start offset, header, keeps header).
    stack = []
    header_start = 0
    paren = 0
    for m in re.finditer(r"[{}()\[\];]", code):
        pos, c = m.start(), m.group(0)
        in_scope = not stack or stack[-1][0] == "scope"
        if c in "([":
            paren += 1
        elif c in ")]":
            paren = max(paren - 1, 0)
        elif c == ";" and in_scope and paren == 0:
            header_start = pos + 1
        elif c == "{":
            if in_scope and paren == 0:
                header = code[header_start:pos]
                kind = classify(header)
                stack.append((kind, header_start, header, paren))
                if kind != "member-init":  # its constructor's header goes on
                    header_start = pos + 1
            else:
                kind = "inner" if stack and stack[-1][0] in ("function", "inner") else "data"
                stack.append((kind, header_start, None, paren))
            paren = 0
        elif c == "}" and stack:
            kind, start, header, outer_paren = stack.pop()
            paren = outer_paren
            if kind == "function":
                first = start + len(header) - len(header.lstrip())
                found.append((code.count("\n", 0, first) + 1, code.count("\n", 0, pos) + 1,
                              function_name(header)))
            if kind in ("function", "scope"):
                header_start = pos + 1
    return found


def python_functions(text):
    found = []

    def visit(body):
        for node in body:
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                first = min([node.lineno] + [d.lineno for d in node.decorator_list])
                found.append((first, node.end_lineno, node.name))
            elif isinstance(node, ast.ClassDef):
                visit(node.body)
            elif isinstance(node, (ast.If, ast.Try, ast.With)):  # functions defined under if/try
                visit(getattr(node, "body", []) + getattr(node, "orelse", []))

    visit(ast.parse(text).body)
    return found


def main(argv):
    check = "--check" in argv
    args = [a for a in argv if not a.startswith("--")]
    limit = int(args[0]) if args else 80
    long_functions, long_files = [], []
    for path in source_files():
        text = open(os.path.join(ROOT, path), encoding="utf-8", errors="replace").read()
        lines = text.count("\n") + (0 if text.endswith("\n") or not text else 1)
        if lines > MAX_FILE_LINES:
            long_files.append((lines, path))
        functions = python_functions(text) if path.endswith(".py") else cxx_functions(text)
        for first, last, name in functions:
            if last - first + 1 > limit:
                long_functions.append((last - first + 1, path, first, name))
    for n, path, line, name in sorted(long_functions, reverse=True):
        print("%4d  %s:%d  %s" % (n, path, line, name))
    print("%d functions over %d lines (at most %d)" % (len(long_functions), limit,
                                                       MAX_LONG_FUNCTIONS))
    for n, path in sorted(long_files, reverse=True):
        print("%4d  %s" % (n, path))
    print("%d files over %d lines (none allowed)" % (len(long_files), MAX_FILE_LINES))
    if check and (len(long_functions) > MAX_LONG_FUNCTIONS or long_files):
        print("FAILED: over the limits of scripts/long_functions.py")
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
