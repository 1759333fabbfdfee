#!/usr/bin/python3
"""scripts/merge_planner_study.py on a tiny synthetic study: a docs dir with one arm (runs.csv
with CRLF line ends, as the merged files in docs/benchmarks/arms/ have, a benchmark.db made
from synthetic OMPL logs, an arms.md with the generated-table markers) and two done chunks:
PRM at 10 s (3 new runs and their OMPL log) and PRM at 20 s (crashed: crash rows, no log).
The merge must replace exactly PRM's rows and database runs of those experiments, keep every
other row byte for byte, and write table lines computed here by hand."""
import os
import shutil
import sqlite3
import sys
import tempfile
import unittest

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "scripts"))
import merge_planner_study  # noqa: E402
import ompl_benchmark_db  # noqa: E402

CONFIG = """\
planners: [SBL, PRM]
benchmarks:
  - {scene: shelf_pick, limit_s: 10, title: "Benchmark 2: pick into the shelf", short: pick}
  - {scene: shelf_place_horizontal, limit_s: 20, title: "Benchmark 3: place, gripper horizontal", short: horizontal}
arms:
  - {robot: ur5, heading: UR5, short: U}
fastest: {count: 1, min_runs: 2}
paper:
  ur5:
    shelf_pick:
      PRM: {time_s: "10.02 (0.00)", path_length_rad: "23.00 (0.00)"}
"""

HEADER = "scene,limit_s,planner,run,solved,time_s,length_rad,cpu_s"
OLD_ROWS = [
    "shelf_pick,10,SBL,0,1,0.004,3,0.003",
    "shelf_pick,10,SBL,1,1,0.008,5,0.005",
    "shelf_pick,10,PRM,0,1,0.5,9,0.4",
    "shelf_pick,10,PRM,1,0,10.02,0,9.5",
    "shelf_place_horizontal,20,SBL,0,1,0.02,2.5,0.01",
    "shelf_place_horizontal,20,PRM,0,1,0.7,8,0.6",
]
# PRM 10 s: solved 2 of 3; times 0.010, 0.030 s; lengths 4, 6 rad; CPU 2, 4 ms and the
# unsolved run at the 10 s limit.
NEW_PRM_10S = [
    "shelf_pick,10,PRM,0,1,0.010,4,0.002",
    "shelf_pick,10,PRM,1,1,0.030,6,0.004",
    "shelf_pick,10,PRM,2,0,10.05,0,9.9",
]
# PRM 20 s crashed: bench_planners' crash rows (unsolved, exactly the limit in time and CPU).
CRASHED_PRM_20S = ["shelf_place_horizontal,20,PRM,0,0,20,0,20", "shelf_place_horizontal,20,PRM,1,0,20,0,20"]

MARKDOWN = ("# Arms\n\nintro text\n\n" + merge_planner_study.BEGIN_MARKER + "\n\nold tables\n\n"
            + merge_planner_study.END_MARKER + "\n\n## Reading\n\n" + merge_planner_study.FASTEST_BEGIN_MARKER
            + "\n\nold fastest\n\n" + merge_planner_study.FASTEST_END_MARKER + "\n\nkept\n")


def ompl_log(scene, limit, planner, runs, total_s):
    """A minimal OMPL benchmark log: runs = [(time, solved, cpu)]."""
    lines = ["OMPL version 1.5.2", "Experiment %s" % scene, "0 experiment properties", "Running on testhost",
             "Starting at 2026-12-04 00:00:00", "<<<|", "setup of %s" % scene,
             "Properties of benchmarked planners:", "%s spec" % planner, "|>>>", "1 is the random seed",
             "%g seconds per run" % limit, "4096 MB per run", "%d runs per planner" % len(runs),
             "%g seconds spent to collect the data" % total_s, "1 enum type", "status|Unknown|Exact",
             "1 planners", "geometric_%s" % planner, "0 common properties", "3 properties for each run",
             "time REAL", "solved BOOLEAN", "cpu time REAL", "%d runs" % len(runs)]
    lines += ["%g; %d; %g; " % run for run in runs]
    lines += ["."]
    return "\n".join(lines) + "\n"


class MergePlannerStudyTest(unittest.TestCase):
    def setUp(self):
        self.tmp = tempfile.mkdtemp()
        self.docs = os.path.join(self.tmp, "docs")
        self.arm = os.path.join(self.docs, "arms", "ur5")
        self.study = os.path.join(self.tmp, "study")
        os.makedirs(self.arm)
        with open(os.path.join(self.docs, "arms", "appendix_tables.yaml"), "w") as f:
            f.write(CONFIG)
        with open(os.path.join(self.docs, "arms.md"), "w") as f:
            f.write(MARKDOWN)
        self.runs_csv = os.path.join(self.arm, "runs.csv")
        with open(self.runs_csv, "w", newline="") as f:
            f.write("".join(line + "\r\n" for line in [HEADER] + OLD_ROWS))
        # the arm's database as an earlier study left it (its logs are gone afterwards)
        logs_dir = os.path.join(self.tmp, "old_logs")
        os.makedirs(logs_dir)
        old_logs = {
            "pick_SBL": ompl_log("shelf_pick", 10, "SBL", [(0.004, 1, 0.003), (0.008, 1, 0.005)], 0.5),
            "pick_PRM": ompl_log("shelf_pick", 10, "PRM", [(0.5, 1, 0.4), (10.02, 0, 9.5)], 11.0),
            "hor_SBL": ompl_log("shelf_place_horizontal", 20, "SBL", [(0.02, 1, 0.01)], 0.3),
            "hor_PRM": ompl_log("shelf_place_horizontal", 20, "PRM", [(0.7, 1, 0.6)], 1.0),
        }
        parsed = []
        for name, text in old_logs.items():
            path = os.path.join(logs_dir, name + ".log")
            with open(path, "w") as f:
                f.write(text)
            parsed.append(ompl_benchmark_db.parse_log(path))
        self.db = os.path.join(self.arm, "benchmark.db")
        ompl_benchmark_db.write_database(parsed, self.db)
        # two done chunks
        chunk = os.path.join(self.study, "ur5", "PRM_10s")
        os.makedirs(chunk)
        with open(os.path.join(chunk, "runs.csv"), "w") as f:
            f.write("\n".join([HEADER] + NEW_PRM_10S) + "\n")
        with open(os.path.join(chunk, "shelf_pick_10s_PRM.log"), "w") as f:
            f.write(ompl_log("shelf_pick", 10, "PRM", [(0.01, 1, 0.002), (0.03, 1, 0.004), (10.05, 0, 9.9)], 10.5))
        with open(os.path.join(chunk, "DONE"), "w") as f:
            f.write("t0 .. t1, commit abc\n")
        crashed = os.path.join(self.study, "ur5", "PRM_20s")
        os.makedirs(crashed)
        with open(os.path.join(crashed, "runs.csv"), "w") as f:
            f.write("\n".join([HEADER] + CRASHED_PRM_20S) + "\n")
        with open(os.path.join(crashed, "DONE"), "w") as f:
            f.write("t2 .. t3, commit abc\n")
        os.makedirs(os.path.join(self.study, "ur5", "LazyPRM_10s"))  # unfinished: no DONE

    def tearDown(self):
        shutil.rmtree(self.tmp)

    def merge(self, *extra):
        return merge_planner_study.main(["--study-dir", self.study, "--docs-dir", self.docs, "--no-plots"] + list(extra))

    def db_runs(self, scene, planner):
        connection = sqlite3.connect(self.db)
        try:
            return connection.execute(
                "SELECT r.time, r.solved, r.cpu_time FROM runs r JOIN experiments e ON e.id = r.experimentid "
                "JOIN plannerConfigs p ON p.id = r.plannerid WHERE e.name=? AND p.name=? ORDER BY r.id",
                (scene, "geometric_" + planner)).fetchall()
        finally:
            connection.close()

    def test_rows_replaced_in_place_others_untouched(self):
        self.assertEqual(self.merge(), 0)
        with open(self.runs_csv, newline="") as f:
            text = f.read()
        expected = [HEADER] + OLD_ROWS[:2] + NEW_PRM_10S + [OLD_ROWS[4]] + CRASHED_PRM_20S
        self.assertEqual(text, "".join(line + "\r\n" for line in expected))

    def test_table_lines_by_hand(self):
        self.assertEqual(self.merge(), 0)
        with open(os.path.join(self.docs, "arms.md")) as f:
            markdown = f.read()
        self.assertTrue(markdown.startswith("# Arms\n\nintro text\n\n" + merge_planner_study.BEGIN_MARKER))
        self.assertTrue(markdown.endswith(merge_planner_study.FASTEST_END_MARKER + "\n\nkept\n"))
        self.assertIn(merge_planner_study.END_MARKER + "\n\n## Reading\n\n" + merge_planner_study.FASTEST_BEGIN_MARKER,
                      markdown)
        self.assertNotIn("old tables", markdown)
        self.assertNotIn("old fastest", markdown)
        lines = markdown.split("\n")
        # PRM pick: 2 of 3 solved = 67 %; time mean 0.020, sd sqrt((0.01^2 + 0.01^2) / 1) =
        # 0.014; CPU median of 2, 4, 10000 ms = 4.0; length mean 5, sd sqrt(2) = 1.41.
        self.assertIn("| PRM | 3 | 67 % | 0.020 (0.014) | 4.0 | 5.00 (1.41) | 10.02 (0.00) | 23.00 (0.00) |", lines)
        # SBL pick (untouched rows): time 0.006 (0.003), CPU median (3 + 5) / 2 = 4.0 ms, length 4 (1.41)
        self.assertIn("| SBL | 2 | 100 % | 0.006 (0.003) | 4.0 | 4.00 (1.41) | - | - |", lines)
        # PRM horizontal crashed: no solved run, CPU at the 20 s limit
        self.assertIn("| PRM | 2 | 0 % (crashed in OMPL) | - | 20000.0 | - | - | - |", lines)
        # SBL horizontal: one run, sd 0
        self.assertIn("| SBL | 1 | 100 % | 0.020 (0.000) | 10.0 | 2.50 (0.00) | - | - |", lines)
        # fastest (1 per benchmark, >= 2 runs all solved): pick: SBL (CPU median 4.0 ms; PRM
        # missed a run); horizontal: nobody (SBL has 1 run, PRM crashed)
        self.assertIn("| arm | pick | horizontal |", lines)
        self.assertIn("| U | SBL 4.0 | - |", lines)
        self.assertIn("### UR5", lines)
        self.assertIn("#### Benchmark 2: pick into the shelf (`shelf_pick`, 10 s)", lines)
        self.assertIn("#### Benchmark 3: place, gripper horizontal (`shelf_place_horizontal`, 20 s)", lines)
        # rows in the configured planner order: SBL before PRM in each table
        self.assertLess(lines.index("| SBL | 2 | 100 % | 0.006 (0.003) | 4.0 | 4.00 (1.41) | - | - |"),
                        lines.index("| PRM | 3 | 67 % | 0.020 (0.014) | 4.0 | 5.00 (1.41) | 10.02 (0.00) | 23.00 (0.00) |"))

    def test_database_planner_runs_replaced(self):
        before_sbl = self.db_runs("shelf_pick", "SBL")
        self.assertEqual(self.merge(), 0)
        self.assertEqual(self.db_runs("shelf_pick", "SBL"), before_sbl)
        self.assertEqual(self.db_runs("shelf_pick", "PRM"), [(0.01, 1, 0.002), (0.03, 1, 0.004), (10.05, 0, 9.9)])
        self.assertEqual(self.db_runs("shelf_place_horizontal", "PRM"), [])  # crashed: deleted
        self.assertEqual(self.db_runs("shelf_place_horizontal", "SBL"), [(0.02, 1, 0.01)])
        connection = sqlite3.connect(self.db)
        try:
            experiments = dict(((name), (runcount, round(total, 6))) for name, runcount, total in
                               connection.execute("SELECT name, runcount, totaltime FROM experiments"))
            orphans = connection.execute("SELECT COUNT(*) FROM runs WHERE plannerid NOT IN "
                                         "(SELECT id FROM plannerConfigs)").fetchone()[0]
        finally:
            connection.close()
        # pick: 0.5 + 11.0 before; PRM's old runs (0.5 + 10.02 s) out, the new log's 10.5 s in
        self.assertEqual(experiments["shelf_pick"], (3, round(0.5 + 11.0 - 10.52 + 10.5, 6)))
        # horizontal: PRM's 0.7 s out, SBL's single run is the largest count
        self.assertEqual(experiments["shelf_place_horizontal"], (1, round(0.3 + 1.0 - 0.7, 6)))
        self.assertEqual(orphans, 0)

    def test_ledger_and_rerun(self):
        self.assertEqual(self.merge(), 0)
        with open(os.path.join(self.arm, "merged_chunks.tsv")) as f:
            ledger = f.read().splitlines()
        self.assertEqual(ledger[0], "planner\tgroup\tchunk\tdone")
        self.assertEqual([line.split("\t")[:2] for line in ledger[1:]], [["PRM", "10s"], ["PRM", "20s"]])
        snapshot = {}
        for name in ("runs.csv", "benchmark.db", "merged_chunks.tsv"):
            with open(os.path.join(self.arm, name), "rb") as f:
                snapshot[name] = f.read()
        self.assertEqual(self.merge(), 0)  # nothing new: nothing changes
        for name, data in snapshot.items():
            with open(os.path.join(self.arm, name), "rb") as f:
                self.assertEqual(f.read(), data, name)

    def test_check(self):
        self.assertEqual(merge_planner_study.main(["--docs-dir", self.docs, "--check"]), 1)  # "old tables"
        self.assertEqual(self.merge(), 0)
        self.assertEqual(merge_planner_study.main(["--docs-dir", self.docs, "--check"]), 0)
        md = os.path.join(self.docs, "arms.md")
        with open(md) as f:
            text = f.read()
        with open(md, "w") as f:
            f.write(text.replace("| 67 % |", "| 68 % |"))
        self.assertEqual(merge_planner_study.main(["--docs-dir", self.docs, "--check"]), 1)

    def test_the_repositorys_tables_are_generated_from_its_runs(self):
        # docs/benchmarks/arms.md's study tables are what the runs.csv files beside them say
        # (no hand edit, no merge that forgot the tables).
        self.assertEqual(merge_planner_study.main(["--tables-only", "--check"]), 0)

    def test_plot_script_is_bench_planners(self):
        script = merge_planner_study.plot_script()
        self.assertIn('fig.savefig("%s/%s_%ss.png" % (out, scene, limit))', script)


if __name__ == "__main__":
    import pyunit_main
    pyunit_main.run("merge_planner_study", MergePlannerStudyTest, sys.argv[1:])
