#!/usr/bin/env python3
"""Functions longer than LINES lines (default 80) in the C++ sources outside
tests/ and fuzz/: from the first line of the signature to the closing brace.

    scripts/long_functions.py [LINES]

A brace counter, not a parser: a definition is a line at the top indentation
of a namespace (or a class body, one level in) that opens a body '{' after a
')' or an initializer list. Good enough to track the project's rule (issue
33: at most 5 functions over 80 lines, each with its reason in the code).
"""
import re
import subprocess
import sys

limit = int(sys.argv[1]) if len(sys.argv) > 1 else 80
files = [f for f in subprocess.check_output(["git", "ls-files", "*.cc", "*.h"]).decode().split()
         if not f.startswith(("tests/", "fuzz/"))]
SIG = re.compile(r"^(\s{0,2})[A-Za-z_~][\w:<>,*&\s\[\]]*[\w>)\]]\s*\(")
found = []
for path in files:
    lines = open(path, encoding="utf-8", errors="replace").read().split("\n")
    i = 0
    while i < len(lines):
        line = lines[i]
        m = SIG.match(line)
        if not m or line.lstrip().startswith(("if", "for", "while", "switch", "return", "//", "#")):
            i += 1
            continue
        # Find the body's '{' within the next 12 lines, before any ';'.
        j, body = i, -1
        while j < len(lines) and j < i + 12:
            text = re.sub(r"//.*", "", lines[j])
            if "{" in text:
                body = j
                break
            if ";" in text:
                break
            j += 1
        if body < 0:
            i += 1
            continue
        depth, k = 0, body
        while k < len(lines):
            text = re.sub(r"//.*|\"(\\.|[^\"\\])*\"|'(\\.|[^'\\])*'", "", lines[k])
            depth += text.count("{") - text.count("}")
            if depth <= 0 and k >= body:
                break
            k += 1
        n = k - i + 1
        name = re.search(r"([~\w:]+)\s*\(", line)
        if n > limit:
            found.append((n, path, i + 1, name.group(1) if name else line.strip()))
        i = k + 1
for n, path, line, name in sorted(found, reverse=True):
    print("%4d  %s:%d  %s" % (n, path, line, name))
print("%d functions over %d lines" % (len(found), limit))
