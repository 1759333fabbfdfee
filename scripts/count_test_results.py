#!/usr/bin/env python3
"""Counts test cases in JUnit XML files (gtest, rostest, rosunit) under a folder.

catkin_test_results counts gtest 1.12's nested <testsuites>/<testsuite> twice, so the
project's summary line comes from the <testcase> elements themselves.
Prints failing cases with their messages, then "N passed, N failed[, N skipped]"; exits 1 on any failure or
when no test ran.
"""
import os
import sys
import xml.etree.ElementTree as ET


def known_failures(root):
    """Test cases listed in <result>.known.xml files: known defects that rosunit wrote as
    passed (it records unittest skips as passes)."""
    known = set()
    for folder, _, files in os.walk(root):
        for name in files:
            if name.endswith(".known.xml"):
                base = name[:-len(".known.xml")] + ".xml"
                for case in ET.parse(os.path.join(folder, name)).iter("testcase"):
                    known.add((os.path.join(folder, base), case.get("classname"), case.get("name")))
    return known


def failure_excerpt(element, max_lines=12):
    """The failure's message and the tail of its text, indented: CI shows only the end of the
    log, so the reason must sit next to the FAILED line."""
    text = (element.get("message") or "") + "\n" + (element.text or "")
    lines = [line for line in text.strip().splitlines() if line.strip()]
    if len(lines) > max_lines:
        lines = lines[:2] + ["..."] + lines[-(max_lines - 3):]
    return "\n".join("    " + line for line in lines) if lines else "    (no message)"


def main(root):
    passed = failed = skipped = 0
    known = known_failures(root)
    for folder, _, files in os.walk(root):
        for name in sorted(files):
            if not name.endswith(".xml") or name.endswith(".known.xml"):
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
                problem = case.find("failure")
                if problem is None:
                    problem = case.find("error")
                if problem is not None:
                    failed += 1
                    print("FAILED: " + label)
                    print(failure_excerpt(problem))
                elif (case.find("skipped") is not None or case.get("status") == "notrun"
                      or (path, case.get("classname"), case.get("name")) in known):
                    skipped += 1
                    if (path, case.get("classname"), case.get("name")) in known:
                        print("KNOWN FAILURE (skipped): " + label)
                else:
                    passed += 1
    line = "%d passed, %d failed" % (passed, failed)
    if skipped:
        line += ", %d skipped" % skipped
    print(line)
    return 1 if failed or passed == 0 else 0


if __name__ == "__main__":
    import argparse
    parser = argparse.ArgumentParser(description="Counts the JUnit test cases under a results folder; "
                                     "last line 'N passed, N failed'.")
    parser.add_argument("root", nargs="?", default=".", help="folder of JUnit XML results (default .)")
    sys.exit(main(parser.parse_args().root))
