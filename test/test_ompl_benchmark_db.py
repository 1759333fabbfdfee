#!/usr/bin/env python3
"""scripts/ompl_benchmark_db.py: OMPL benchmark logs -> Planner Arena's SQLite tables.

The fixtures in test/ompl_logs/ are logs bench_planners wrote (narrow_passage, 2 runs each;
RRTstar adds progress samples). With --bench-planners PATH (CMakeLists passes the built tool)
a short live bench_planners run must leave <out>/benchmark.db and print its path.
"""
import os
import sqlite3
import subprocess
import sys
import tempfile
import unittest

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "scripts"))
import ompl_benchmark_db  # noqa: E402

LOGS = os.path.join(HERE, "ompl_logs")
BENCH_PLANNERS = None  # set from --bench-planners


def fixture(name):
    return os.path.join(LOGS, name)


def query(db, sql, *args):
    connection = sqlite3.connect(db)
    try:
        return connection.execute(sql, args).fetchall()
    finally:
        connection.close()


class OmplBenchmarkDbTest(unittest.TestCase):
    def setUp(self):
        self.tmp = tempfile.TemporaryDirectory()
        self.db = os.path.join(self.tmp.name, "benchmark.db")

    def tearDown(self):
        self.tmp.cleanup()

    def convert(self, *names, version="1.5.2"):
        return ompl_benchmark_db.write_database([ompl_benchmark_db.parse_log(fixture(n)) for n in names], self.db,
                                                library_version=version)

    def test_tables_and_rows_of_one_experiment(self):
        counts = self.convert("narrow_passage_0.5s_RRTConnect.log", "narrow_passage_0.5s_RRTstar.log")
        tables = {row[0] for row in query(self.db, "SELECT name FROM sqlite_master WHERE type='table'")}
        self.assertTrue({"experiments", "plannerConfigs", "runs", "progress", "enums"} <= tables, tables)
        # Both planners' logs are one experiment (same scene and time limit).
        experiments = query(self.db, "SELECT name, timelimit, runcount, version FROM experiments")
        self.assertEqual(experiments, [("narrow_passage", 0.5, 2, "OMPL 1.5.2")])
        planners = sorted(row[0] for row in query(self.db, "SELECT name FROM plannerConfigs"))
        self.assertEqual(planners, ["geometric_RRTConnect", "geometric_RRTstar"])
        settings = query(self.db, "SELECT settings FROM plannerConfigs WHERE name='geometric_RRTConnect'")[0][0]
        self.assertIn("range = 0.3125;", settings)
        self.assertEqual(counts["runs"], 4)
        columns = {row[1] for row in query(self.db, "PRAGMA table_info(runs)")}
        for column in ("time", "solved", "status", "simplified_solution_length", "approximate_solution"):
            self.assertIn(column, columns)
        # Values are typed: times are REAL, the status an enum value with a name.
        rows = query(self.db, "SELECT p.name, r.time, r.status, r.solved FROM runs r "
                              "JOIN plannerConfigs p ON p.id = r.plannerid ORDER BY r.id")
        self.assertEqual(len(rows), 4)
        for name, time, status, solved in rows:
            self.assertIsInstance(time, float)
            self.assertGreater(time, 0.0)
            self.assertIn(solved, (0, 1))
            self.assertIsInstance(status, int)
        exact = query(self.db, "SELECT value FROM enums WHERE name='status' AND description='Exact solution'")
        self.assertEqual(len(exact), 1)
        rrtconnect_status = query(self.db, "SELECT r.status FROM runs r JOIN plannerConfigs p ON p.id = r.plannerid "
                                           "WHERE p.name='geometric_RRTConnect'")
        self.assertEqual([s for (s,) in rrtconnect_status], [exact[0][0]] * 2)
        # Progress samples belong to RRTstar's runs only, with the log's columns.
        progress = query(self.db, "SELECT DISTINCT p.name FROM progress g JOIN runs r ON r.id = g.runid "
                                  "JOIN plannerConfigs p ON p.id = r.plannerid")
        self.assertEqual(progress, [("geometric_RRTstar",)])
        self.assertGreater(counts["progress"], 0)
        progress_columns = {row[1] for row in query(self.db, "PRAGMA table_info(progress)")}
        self.assertTrue({"runid", "time", "best_cost", "iterations"} <= progress_columns, progress_columns)

    def test_time_limits_are_separate_experiments(self):
        self.convert("narrow_passage_0.5s_RRTConnect.log", "narrow_passage_1s_RRTConnect.log")
        names = sorted(row[0] for row in query(self.db, "SELECT name FROM experiments"))
        self.assertEqual(names, ["narrow_passage 0.5s", "narrow_passage 1s"])

    def test_database_is_replaced_not_appended(self):
        self.convert("narrow_passage_0.5s_RRTConnect.log")
        counts = self.convert("narrow_passage_0.5s_RRTConnect.log")
        self.assertEqual((counts["experiments"], counts["runs"]), (1, 2))

    def test_update_replaces_one_planner_in_place(self):
        self.convert("narrow_passage_0.5s_RRTConnect.log", "narrow_passage_0.5s_RRTstar.log")
        rrtstar_sql = ("SELECT r.time, r.solved, g.time, g.best_cost FROM runs r JOIN plannerConfigs p "
                       "ON p.id = r.plannerid LEFT JOIN progress g ON g.runid = r.id "
                       "WHERE p.name='geometric_RRTstar' ORDER BY r.id, g.time")
        rrtstar = query(self.db, rrtstar_sql)
        self.assertTrue(rrtstar)
        # The 1 s log's RRTConnect runs, renamed into the 0.5 s experiment, replace the old ones.
        log = ompl_benchmark_db.parse_log(fixture("narrow_passage_1s_RRTConnect.log"))
        log["timelimit"] = 0.5
        new_times = [run[[n for n, _ in log["planners"][0]["properties"]].index("time")]
                     for run in log["planners"][0]["runs"]]
        ompl_benchmark_db.update_database(self.db, [log])
        self.assertEqual(query(self.db, "SELECT name, timelimit, runcount FROM experiments"),
                         [("narrow_passage", 0.5, 2)])
        rrtconnect = query(self.db, "SELECT r.time FROM runs r JOIN plannerConfigs p ON p.id = r.plannerid "
                                    "WHERE p.name='geometric_RRTConnect' ORDER BY r.id")
        self.assertEqual([t for (t,) in rrtconnect], new_times)
        self.assertEqual(query(self.db, rrtstar_sql), rrtstar)  # the other planner untouched
        self.assertEqual(query(self.db, "SELECT COUNT(*) FROM progress WHERE runid NOT IN (SELECT id FROM runs)"),
                         [(0,)])
        # A log of a time limit the database lacks adds its experiment (named apart by its limit),
        # through the command line.
        self.assertEqual(ompl_benchmark_db.main(["--update", "-o", self.db, fixture("narrow_passage_1s_RRTConnect.log")]),
                         0)
        self.assertEqual(sorted(query(self.db, "SELECT name, timelimit, runcount FROM experiments")),
                         [("narrow_passage", 0.5, 2), ("narrow_passage 1s", 1.0, 2)])

    def test_missing_version_gets_the_fallback(self):
        self.convert("narrow_passage_0.5s_RRTConnect.log", version=None)
        self.assertEqual(query(self.db, "SELECT version FROM experiments"), [("OMPL 0.0.0",)])

    def test_malformed_log_names_file_and_line(self):
        with open(fixture("narrow_passage_0.5s_RRTConnect.log")) as f:
            lines = f.read().split("\n")
        cut = [i for i, line in enumerate(lines) if line.endswith("properties for each run")][0]
        broken = os.path.join(self.tmp.name, "broken.log")
        with open(broken, "w") as f:
            f.write("\n".join(lines[:cut + 3]))  # the run lines are missing
        with self.assertRaises(ompl_benchmark_db.LogFormatError) as error:
            ompl_benchmark_db.parse_log(broken)
        self.assertIn("broken.log:", str(error.exception))
        self.assertEqual(ompl_benchmark_db.main(["-o", self.db, broken]), 1)
        self.assertFalse(os.path.exists(self.db))

    def test_bench_planners_writes_the_database(self):
        if not BENCH_PLANNERS:
            self.skipTest("no --bench-planners given")
        out = os.path.join(self.tmp.name, "bench")
        result = subprocess.run([BENCH_PLANNERS, "--runs", "2", "--planners", "RRTConnect,BiTRRT", "--scenes",
                                 "narrow_passage", "--limits", "1", "--end-to-end", "none", "--out", out],
                                stdout=subprocess.PIPE, stderr=subprocess.STDOUT, universal_newlines=True,
                                timeout=300)
        self.assertEqual(result.returncode, 0, result.stdout)
        db = os.path.join(out, "benchmark.db")
        self.assertIn("Planner Arena database: " + os.path.abspath(db), result.stdout)
        self.assertEqual(query(db, "SELECT name, timelimit, runcount FROM experiments"), [("narrow_passage", 1.0, 2)])
        self.assertEqual(query(db, "SELECT COUNT(*) FROM runs"), [(4,)])
        self.assertEqual(query(db, "SELECT version FROM experiments"), [("OMPL 1.5.2",)])


if __name__ == "__main__":
    import pyunit_main
    args = sys.argv[1:]
    BENCH_PLANNERS = pyunit_main.take_flag(args, "--bench-planners") or BENCH_PLANNERS
    pyunit_main.run("test_ompl_benchmark_db", OmplBenchmarkDbTest, args)
