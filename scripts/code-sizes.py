#!/usr/bin/env python3
"""Sizes of RVWO's C++ code: files over a line limit, functions over a line limit, and every
app's main over its own limit.

    python3 scripts/code-sizes.py [--check] [--function-lines 120] [--file-lines 800]
                                  [--main-lines 60] [--allow FILE] [paths...]

Functions are found by layout, which clang-format keeps regular: a definition is a statement
that ends in '{' outside any function, has a parameter list and is not a class, namespace,
enum or control statement; its length is from its first line to its closing brace. Lambdas and
local classes count towards the function they are in. Paths default to the tracked *.cc and *.h
files outside tests/ and benchmarks/.

--check exits 1 when something is over its limit and not named in the --allow file (one
"path:function" or "path" a line, # for comments): the list of what is still to split, which
may only shrink.
"""
import argparse
import os
import re
import subprocess
import sys

NOT_A_FUNCTION = re.compile(r"^\s*(template\s*<.*>\s*)?(class|struct|union|enum|namespace|extern\s+\"C\"\s*$|if|for|while|switch|else|do|try|catch|return)\b")


def tracked_sources(root):
    out = subprocess.run(["git", "ls-files", "*.cc", "*.h"], cwd=root, capture_output=True, text=True,
                         check=True).stdout.split()
    return [p for p in out if not p.startswith(("tests/", "benchmarks/"))]


def strip(line):
    """The line without // comments and string or character literals."""
    line = re.sub(r'"(\\.|[^"\\])*"', '""', line)
    line = re.sub(r"'(\\.|[^'\\])*'", "''", line)
    return line.split("//", 1)[0]


def functions(lines):
    """(name, first line, last line), 1-based, of the function definitions in a file."""
    found = []
    depth = 0            # braces open
    fn_depth = None      # depth at which the current function's body opened
    start = None         # first line of the statement being read (outside functions)
    start_depth = 0      # depth where it began
    inline_body = None   # depth of a one-line body's brace
    text = ""
    for i, raw in enumerate(lines):
        line = strip(raw)
        if line.lstrip().startswith("#"):
            continue
        if fn_depth is None and line.strip():
            if start is None:
                start, start_depth, text = i, depth, ""
            text += " " + line.strip()
        for j, ch in enumerate(line):
            if ch == "{":
                # A body's brace ends its line; one inside a statement (a default argument's {}, an
                # initialiser list) does not.
                ends_line = line[j + 1:].strip() == ""
                if fn_depth is None and start is not None and ends_line:
                    head = text[:text.rfind("{")]
                    if "(" in head and not NOT_A_FUNCTION.match(head) and not re.search(r"=\s*\[", head):
                        name = re.findall(r"([~\w:]+|operator\S+)\s*\(", head)
                        fn_depth = depth
                        found.append([name[0] if name else "?", start + 1, None])
                    start = None
                elif fn_depth is None and start is not None and re.search(
                        r"(\)|\bconst|\boverride|\bnoexcept|\bfinal)\s*$", line[:j]):
                    inline_body = depth  # a one-line body: the statement ends with it
                depth += 1
            elif ch == "}":
                depth -= 1
                if fn_depth is not None and depth == fn_depth:
                    found[-1][2] = i + 1
                    fn_depth = None
                if start is not None and (depth < start_depth or depth == inline_body):
                    start = None
                if depth == inline_body:
                    inline_body = None
            elif ch == ";" and fn_depth is None and start is not None and depth == start_depth:
                start = None
        if fn_depth is None and start is not None and line.rstrip().endswith(":") and "(" not in text:
            start = None  # an access specifier or a label
    return [tuple(f) for f in found if f[2] is not None]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("paths", nargs="*")
    ap.add_argument("--check", action="store_true")
    ap.add_argument("--function-lines", type=int, default=120)
    ap.add_argument("--file-lines", type=int, default=800)
    ap.add_argument("--main-lines", type=int, default=60)
    ap.add_argument("--allow", help="what is known to be over, one path or path:function a line")
    ap.add_argument("--root", default=os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
    a = ap.parse_args()
    root = os.path.abspath(a.root)
    paths = a.paths or tracked_sources(root)
    allowed = set()
    if a.allow:
        with open(a.allow) as f:
            allowed = {l.split("#", 1)[0].strip() for l in f} - {""}
    over = []
    for p in paths:
        with open(os.path.join(root, p), encoding="utf-8") as f:
            lines = f.read().split("\n")
        n = len(lines) - (lines[-1] == "")
        if n > a.file_lines:
            over.append((p, f"{p}: {n} lines (file limit {a.file_lines})"))
        for name, first, last in functions(lines):
            length = last - first + 1
            limit = a.main_lines if name == "main" and p.startswith("apps/") else a.function_lines
            if length > limit:
                over.append((f"{p}:{name}", f"{p}:{first}: {name}, {length} lines (limit {limit})"))
    unexpected = [msg for key, msg in over if key not in allowed]
    for key, msg in over:
        print(msg + ("" if key not in allowed or not a.check else "  [allowed]"))
    if not over:
        print("code sizes: nothing over its limit")
    stale = sorted(allowed - {key for key, _ in over})
    if a.check and stale:
        print("allowed but no longer over (remove from the list): " + ", ".join(stale))
    return 1 if a.check and (unexpected or stale) else 0


if __name__ == "__main__":
    sys.exit(main())
