#!/usr/bin/env python3
"""Counts test cases in JUnit XML files (gtest, rostest, rosunit) under a folder.

catkin_test_results counts gtest 1.12's nested <testsuites>/<testsuite> twice, so the
project's summary line comes from the <testcase> elements themselves.
Prints failing cases, then "N passed, N failed[, N skipped]"; exits 1 on any failure or
when no test ran.
"""
import os
import sys
import xml.etree.ElementTree as ET


def main(root):
    passed = failed = skipped = 0
    for folder, _, files in os.walk(root):
        for name in sorted(files):
            if not name.endswith(".xml"):
                continue
            path = os.path.join(folder, name)
            try:
                tree = ET.parse(path)
            except ET.ParseError as error:
                print("unreadable result file %s: %s" % (path, error))
                failed += 1
                continue
            cases = list(tree.iter("testcase"))
            if not cases:
                print("no test case in %s" % path)
                failed += 1
                continue
            for case in cases:
                label = "%s.%s (%s)" % (case.get("classname"), case.get("name"), name)
                if case.find("failure") is not None or case.find("error") is not None:
                    failed += 1
                    print("FAILED: " + label)
                elif case.find("skipped") is not None or case.get("status") == "notrun":
                    skipped += 1
                else:
                    passed += 1
    line = "%d passed, %d failed" % (passed, failed)
    if skipped:
        line += ", %d skipped" % skipped
    print(line)
    return 1 if failed or passed == 0 else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1] if len(sys.argv) > 1 else "."))
