"""The `__main__` of the package's Python unit tests that CMake runs with catkin_run_tests_target:
with --gtest_output=xml:FILE (as CMake passes it) rosunit writes the JUnit file the summary
counts; without it, plain unittest (for a run by hand)."""
import sys
import unittest


def take_flag(args, flag):
    """Removes `flag VALUE` from args and returns VALUE (None when absent)."""
    if flag not in args:
        return None
    i = args.index(flag)
    value = args[i + 1]
    del args[i:i + 2]
    return value


def run(test_name, case, args):
    if any(a.startswith("--gtest_output=xml:") for a in args):
        import rosunit
        rosunit.unitrun("fast_grasp", test_name, case, sysargs=[sys.argv[0]] + args)
    else:
        unittest.main(argv=[sys.argv[0]] + args)
