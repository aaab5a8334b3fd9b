#!/usr/bin/env python3
"""Fails on a test that skipped without being expected to.

    .ci/skips.py JUNIT.xml [EXPECTED]      (EXPECTED default: .ci/expected-skips.txt)

JUNIT.xml is what `ctest --output-junit` wrote. A gtest case that calls GTEST_SKIP passes in
ctest's summary, so a test whose tool is missing (strace, say) would be silently not run on a
fresh machine. Each line of EXPECTED names a test (as ctest does, Suite.Case) that may skip, and
why; anything else that skipped fails the stage.
"""
import os
import sys
import xml.etree.ElementTree as ET


def expected_skips(path):
    names = {}
    for line in open(path, encoding="utf-8"):
        line = line.strip()
        if not line or line.startswith("#"):
            continue
        name, _, why = line.partition(" ")
        names[name] = why.strip()
    return names


def main():
    if len(sys.argv) not in (2, 3):
        sys.exit(__doc__)
    here = os.path.dirname(os.path.abspath(__file__))
    allowed = expected_skips(sys.argv[2] if len(sys.argv) == 3 else
                             os.path.join(here, "expected-skips.txt"))
    skipped = []
    for case in ET.parse(sys.argv[1]).getroot().iter("testcase"):
        if case.get("status") == "skipped" or case.find("skipped") is not None:
            skipped.append(case.get("name"))
    unexpected = [n for n in skipped if n not in allowed]
    for n in skipped:
        print(f"skips: {n}: {'expected: ' + allowed[n] if n in allowed else 'NOT EXPECTED'}")
    if unexpected:
        print(f"skips: {len(unexpected)} test(s) skipped that should run here (install what they "
              f"need in scripts/deps.sh, or list them in .ci/expected-skips.txt with the reason)",
              file=sys.stderr)
        sys.exit(1)
    print(f"skips: {len(skipped)} skipped, all expected")


main()
