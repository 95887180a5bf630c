#!/usr/bin/env python3
"""Counts test cases in JUnit XML files (gtest, rostest, rosunit) under a folder.

catkin_test_results counts both <testsuites> and <testsuite> totals; this counts <testcase>
elements once each. Prints: passed failed skipped, then one line per failed case.
"""
import sys
import xml.etree.ElementTree as ET
from pathlib import Path


def main(root):
    passed = failed = skipped = 0
    failures = []
    for path in sorted(Path(root).rglob("*.xml")):
        try:
            tree = ET.parse(path)
        except ET.ParseError as exc:
            failed += 1
            failures.append(f"{path.name}: unreadable result file ({exc})")
            continue
        cases = list(tree.getroot().iter("testcase"))
        if not cases:
            # A suite that failed before any case ran (e.g. a rostest whose node died).
            root_el = tree.getroot()
            errs = int(root_el.get("errors", 0) or 0) + int(root_el.get("failures", 0) or 0)
            if errs:
                failed += 1
                failures.append(f"{path.name}: suite failed with no test case")
            continue
        for case in cases:
            name = f"{path.name}: {case.get('classname', '')}.{case.get('name', '')}"
            if case.find("failure") is not None or case.find("error") is not None:
                failed += 1
                failures.append(name)
            elif case.find("skipped") is not None or case.get("status") == "notrun":
                skipped += 1
            else:
                passed += 1
    print(passed, failed, skipped)
    for f in failures:
        print("FAILED", f)


if __name__ == "__main__":
    main(sys.argv[1])
