#!/usr/bin/python3
"""Every executable of the package follows one command-line convention (src/tools/command_line.h):
--help prints the usage on stdout and exits 0; an unknown flag prints the usage on stderr and
exits 2. Run on the built binaries (--bin-dir) and the user-facing Python scripts."""
import os
import subprocess
import sys
import unittest

BIN_DIR = None
HERE = os.path.dirname(os.path.abspath(__file__))
EXECUTABLES = ["grasp_offline", "arm_offline", "render_bag", "scene_camera", "bench_ik", "bench_planners",
               "bench_perception", "bench_segmentation", "bench_grasps", "bench_grasp_motions", "bench_clutter"]
SCRIPTS = ["evaluate_grasps_physics.py", "evaluate_clutter_physics.py", "make_clutter_scenes.py", "evaluate_grasps.py",
           "ompl_benchmark_db.py", "count_test_results.py", "soak.py"]
SHELL_SCRIPTS = ["soak.sh", "fuzz.sh", "build_sanitized.sh", "sanitizer_tests.sh"]


def run(command):
    return subprocess.run(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, timeout=60,
                          universal_newlines=True)


class CommandLineTest(unittest.TestCase):
    def check(self, command):
        helped = run(command + ["--help"])
        self.assertEqual(helped.returncode, 0, "%s --help: %s" % (command, helped.stderr))
        self.assertIn("usage", helped.stdout.lower(), "%s --help printed no usage on stdout" % command)
        wrong = run(command + ["--no-such-flag"])
        self.assertEqual(wrong.returncode, 2, "%s --no-such-flag exited %d" % (command, wrong.returncode))
        self.assertIn("usage", wrong.stderr.lower(), "%s --no-such-flag printed no usage on stderr" % command)

    def test_executables(self):
        for name in EXECUTABLES:
            with self.subTest(name=name):
                self.check([os.path.join(BIN_DIR, name)])

    def test_scripts(self):
        for name in SCRIPTS:
            with self.subTest(name=name):
                self.check(["/usr/bin/python3", os.path.join(HERE, "..", "scripts", name)])

    def test_shell_scripts(self):
        for name in SHELL_SCRIPTS:
            with self.subTest(name=name):
                self.check(["/bin/bash", os.path.join(HERE, "..", "scripts", name)])


if __name__ == "__main__":
    import pyunit_main
    args = sys.argv[1:]
    BIN_DIR = pyunit_main.take_flag(args, "--bin-dir")
    pyunit_main.run("command_line", CommandLineTest, args)
