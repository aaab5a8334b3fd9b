#!/usr/bin/env python3
"""Source size limits: no file in src/ or include/ over 700 lines, no function body outside
tests over 120 lines. Functions are found by their braces: a line that ends a signature with
`{` at namespace or class depth opens one; comments and strings are skipped. Prints each
offender; exit 1 if any."""
import os
import re
import sys

MAX_FILE, MAX_FUNC = 700, 120
root = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")


def strip(text):
    # Comments, string and character literals out, newlines kept (line numbers stay).
    out, i, n = [], 0, len(text)
    while i < n:
        c = text[i]
        if text.startswith("//", i):
            j = text.find("\n", i)
            i = n if j < 0 else j
        elif text.startswith("/*", i):
            j = text.find("*/", i + 2)
            j = n if j < 0 else j + 2
            out.append("\n" * text.count("\n", i, j))
            i = j
        elif c in "\"'":
            if c == '"' and i > 0 and text[i - 1] == "R":  # raw string R"d(...)d"
                d = text[i + 1:text.find("(", i)]
                j = text.find(")" + d + '"', i) + len(d) + 2
            else:
                j = i + 1
                while j < n and text[j] != c:
                    j += 2 if text[j] == "\\" else 1
                j += 1
            out.append("\n" * text.count("\n", i, j))
            i = j
        else:
            out.append(c)
            i += 1
    return "".join(out)


SIG = re.compile(r"\)\s*(const)?\s*(noexcept)?\s*(override)?\s*(->\s*[\w:<>,\s*&]+)?\s*\{\s*$")
CTRL = re.compile(r"^\s*(if|for|while|switch|catch|else|do)\b|\[[^\]]*\]\s*\(")


def functions(path):
    lines = strip(open(path, encoding="utf-8", errors="replace").read()).split("\n")
    depth, stack, found = 0, [], []
    for no, line in enumerate(lines, 1):
        opens_fn = bool(SIG.search(line)) and not CTRL.search(line)
        for ch in line:
            if ch == "{":
                stack.append((depth, no if opens_fn and not any(s[1] for s in stack) else 0))
                depth += 1
                opens_fn = False
            elif ch == "}":
                depth -= 1
                if stack:
                    _, start = stack.pop()
                    if start:
                        found.append((start, no))
    return found


def main():
    bad = []
    for top in ("src", "include", "tests", "bench", "examples"):
        for d, _, files in os.walk(os.path.join(root, top)):
            for f in files:
                if not f.endswith((".cpp", ".hpp", ".h", ".cc")):
                    continue
                p = os.path.join(d, f)
                rel = os.path.relpath(p, root)
                n = sum(1 for _ in open(p, encoding="utf-8", errors="replace"))
                if top in ("src", "include") and n > MAX_FILE:
                    bad.append(f"{rel}: {n} lines (limit {MAX_FILE})")
                if top == "tests":
                    continue
                for a, b in functions(p):
                    if b - a + 1 > MAX_FUNC:
                        bad.append(f"{rel}:{a}: a function of {b - a + 1} lines (limit {MAX_FUNC})")
    for b in bad:
        print(b)
    print(f"check-sizes: {len(bad)} over the limits")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
