"""The `__main__` of the package's Python unit tests that CMake runs with catkin_run_tests_target:
with --gtest_output=xml:FILE (as CMake passes it) the JUnit file the summary counts is written
(by rosunit where it is importable; in the physics venv, which has no ROS, by junit_run below);
without it, plain unittest (for a run by hand)."""
import os
import sys
import time
import unittest
from xml.sax.saxutils import quoteattr


def take_flag(args, flag):
    """Removes `flag VALUE` from args and returns VALUE (None when absent)."""
    if flag not in args:
        return None
    i = args.index(flag)
    value = args[i + 1]
    del args[i:i + 2]
    return value


def run(test_name, case, args):
    xml = [a for a in args if a.startswith("--gtest_output=xml:")]
    if not xml:
        unittest.main(argv=[sys.argv[0]] + args)
        return
    try:
        import rosunit
    except ImportError:
        junit_run(test_name, case, xml[0].split(":", 1)[1])
        return
    rosunit.unitrun("fast_grasp", test_name, case, sysargs=[sys.argv[0]] + args)


def junit_run(test_name, case, xml_path):
    """Runs the case with unittest and writes a JUnit XML file like rosunit's; exits 1 on failure."""
    suite = unittest.defaultTestLoader.loadTestsFromTestCase(case)
    result = unittest.TestResult()
    times = {}
    start = time.time()
    for test in suite:
        t0 = time.time()
        test.run(result)
        times[test.id()] = time.time() - t0
    problems = {t.id(): ("failure", text) for t, text in result.failures}
    problems.update({t.id(): ("error", text) for t, text in result.errors})
    lines = ['<?xml version="1.0" encoding="utf-8"?>',
             '<testsuite name=%s tests="%d" failures="%d" errors="%d" time="%.3f">'
             % (quoteattr(test_name), len(times), len(result.failures), len(result.errors), time.time() - start)]
    for test_id, seconds in times.items():
        lines.append('  <testcase classname=%s name=%s time="%.3f">'
                     % (quoteattr(test_id.rsplit(".", 1)[0]), quoteattr(test_id.rsplit(".", 1)[1]), seconds))
        if test_id in problems:
            kind, text = problems[test_id]
            lines.append('    <%s message=%s/>' % (kind, quoteattr(text[-2000:])))
            sys.stderr.write("%s %s:\n%s\n" % (kind.upper(), test_id, text))
        lines.append("  </testcase>")
    lines.append("</testsuite>")
    os.makedirs(os.path.dirname(xml_path) or ".", exist_ok=True)
    with open(xml_path, "w") as f:
        f.write("\n".join(lines) + "\n")
    print("%s: %d tests, %d failures, %d errors" % (test_name, len(times), len(result.failures), len(result.errors)))
    sys.exit(0 if result.wasSuccessful() else 1)
