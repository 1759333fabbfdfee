#!/usr/bin/env python3
"""OMPL benchmark logs (ompl::tools::Benchmark::saveResultsToFile) -> SQLite database that
Planner Arena (plannerarena.org, or its local R/Shiny app) opens.

Debian's libompl-dev does not ship OMPL's ompl_benchmark_statistics.py, so this is a
standard-library-only reader of the same log format writing the same tables:
  experiments    one row per experiment (here: scene + time limit)
  plannerConfigs one row per planner name + settings (the log's "common properties")
  enums          value names of ENUM properties (the run status)
  runs           one row per run, one column per run property ("time REAL" -> time)
  progress       progress samples of optimizing planners (runid, time, best_cost, ...)

bench_planners writes one log per scene, time limit and planner (each planner runs in its own
process); logs with the same experiment name and time limit become one experiment, so Planner
Arena shows all planners of a scene side by side. When one name has several time limits, the
experiment names get the limit appended ("narrow_passage 3s").

Usage: ompl_benchmark_db.py [-o benchmark.db] [--library-version 1.5.2] [--update] LOG [LOG ...]
The database is replaced, not appended to; with --update an existing database keeps everything
but the runs of the logs' planners in the logs' experiments, which the logs' runs replace (for
a database whose other logs are gone, as scripts/merge_planner_study.py folds in new runs).
"""
import argparse
import contextlib
import os
import shutil
import sqlite3
import sys
import tempfile

SCHEMA = """
CREATE TABLE experiments
  (id INTEGER PRIMARY KEY AUTOINCREMENT, name VARCHAR(512), totaltime REAL, timelimit REAL,
   memorylimit REAL, runcount INTEGER, version VARCHAR(128), hostname VARCHAR(1024),
   cpuinfo TEXT, date DATETIME, seed INTEGER, setup TEXT);
CREATE TABLE plannerConfigs
  (id INTEGER PRIMARY KEY AUTOINCREMENT, name VARCHAR(512) NOT NULL, settings TEXT);
CREATE TABLE enums
  (name VARCHAR(512), value INTEGER, description TEXT, PRIMARY KEY (name, value));
CREATE TABLE runs
  (id INTEGER PRIMARY KEY AUTOINCREMENT, experimentid INTEGER, plannerid INTEGER,
   FOREIGN KEY (experimentid) REFERENCES experiments(id) ON DELETE CASCADE,
   FOREIGN KEY (plannerid) REFERENCES plannerConfigs(id) ON DELETE CASCADE);
CREATE TABLE progress
  (runid INTEGER, time REAL, PRIMARY KEY (runid, time),
   FOREIGN KEY (runid) REFERENCES runs(id) ON DELETE CASCADE);
"""

MISSING_VALUES = {"", "nan", "-nan", "inf", "-inf"}


class LogFormatError(ValueError):
    pass


class LogReader:
    """Line reader that names the file and line in every format error."""

    def __init__(self, path):
        self.path = path
        with open(path, "r", encoding="utf-8", errors="replace") as f:
            self.lines = f.read().split("\n")
        self.index = 0

    def error(self, message):
        return LogFormatError("%s:%d: %s" % (self.path, self.index, message))

    def peek(self):
        return self.lines[self.index] if self.index < len(self.lines) else None

    def next(self):
        line = self.peek()
        if line is None:
            raise self.error("unexpected end of file")
        self.index += 1
        return line

    def count(self, suffix):
        """Reads '<n> <suffix>' and returns n."""
        line = self.next()
        words = line.split()
        if len(words) < 2 or " ".join(words[1:]) != suffix:
            raise self.error("expected '<n> %s', got '%s'" % (suffix, line))
        try:
            return int(words[0])
        except ValueError:
            raise self.error("expected a count in '%s'" % line)

    def optional_count(self, suffixes):
        line = self.peek()
        if line is None:
            return None
        words = line.split()
        if len(words) >= 2 and " ".join(words[1:]) in suffixes:
            return self.count(" ".join(words[1:]))
        return None

    def block(self, required):
        """Reads a '<<<|' ... '|>>>' block; None when optional and absent."""
        if self.peek() != "<<<|":
            if required:
                raise self.error("expected '<<<|'")
            return None
        self.next()
        text = []
        while True:
            line = self.next()
            if line.startswith("|>>>"):
                return "\n".join(text) + ("\n" if text else "")
            text.append(line)


def column_name(words):
    """'approx goal distance' -> 'approx_goal_distance' (OMPL's naming)."""
    return "_".join(words)


def typed_value(text, sql_type):
    text = text.strip()
    if text in MISSING_VALUES:
        return None
    try:
        if sql_type.upper() in ("INTEGER", "BOOLEAN", "ENUM"):
            return int(float(text))
        return float(text)
    except ValueError:
        return text


def parse_properties(reader, count):
    """'<name words> <TYPE>' lines -> [(column, TYPE)]."""
    properties = []
    for _ in range(count):
        words = reader.next().split()
        if len(words) < 2:
            raise reader.error("expected '<property name> <TYPE>'")
        properties.append((column_name(words[:-1]), words[-1]))
    return properties


def parse_log(path):
    """One benchmark log -> dict with the experiment's fields and its planners."""
    reader = LogReader(path)
    log = {"path": path}
    first = reader.next().split()
    if len(first) < 2 or first[1] != "version":
        raise reader.error("expected '<library> version <x>'")
    log["library"] = first[0]
    log["version"] = " ".join(first[2:])
    words = reader.next().split()
    if not words or words[0] != "Experiment":
        raise reader.error("expected 'Experiment <name>'")
    log["name"] = " ".join(words[1:])
    log["parameters"] = []
    parameter_count = reader.optional_count({"experiment properties"})
    for _ in range(parameter_count or 0):
        key, _, value = reader.next().partition("=")
        key_words = key.split()
        if len(key_words) < 2:
            raise reader.error("expected '<name> <TYPE> = <value>'")
        log["parameters"].append((column_name(key_words[:-1]), key_words[-1], value.strip()))
    words = reader.next().split()
    if words[:2] != ["Running", "on"]:
        raise reader.error("expected 'Running on <host>'")
    log["hostname"] = " ".join(words[2:])
    words = reader.next().split()
    if words[:2] != ["Starting", "at"]:
        raise reader.error("expected 'Starting at <date>'")
    log["date"] = " ".join(words[2:])
    log["setup"] = reader.block(required=True)
    log["cpuinfo"] = reader.block(required=False)

    def leading_number(suffix, kind=float):
        line = reader.next()
        words = line.split()
        if len(words) < 2 or " ".join(words[1:]) != suffix:
            raise reader.error("expected '<value> %s', got '%s'" % (suffix, line))
        return kind(words[0])

    log["seed"] = leading_number("is the random seed", int)
    log["timelimit"] = leading_number("seconds per run")
    log["memorylimit"] = leading_number("MB per run")
    runs_per_planner = reader.optional_count({"runs per planner"})
    log["runcount"] = -1 if runs_per_planner is None else runs_per_planner
    log["totaltime"] = leading_number("seconds spent to collect the data")
    log["enums"] = []
    enum_count = reader.optional_count({"enum type", "enum types"})
    for _ in range(enum_count or 0):
        fields = reader.next().split("|")
        log["enums"].append((fields[0], fields[1:]))
    log["planners"] = []
    for _ in range(reader.count("planners")):
        planner = {"name": reader.next().strip()}
        settings = ""
        for _ in range(reader.count("common properties")):
            settings += reader.next() + ";"
        planner["settings"] = settings
        planner["properties"] = parse_properties(reader, reader.count("properties for each run"))
        planner["runs"] = []
        for _ in range(reader.count("runs")):
            values = reader.next().split("; ")
            if values and values[-1].strip() == "":
                values = values[:-1]
            if len(values) != len(planner["properties"]):
                raise reader.error("a run has %d values for %d properties" % (len(values), len(planner["properties"])))
            planner["runs"].append([typed_value(v, t) for v, (_, t) in zip(values, planner["properties"])])
        planner["progress_properties"] = []
        planner["progress"] = []
        line = reader.next().strip()
        if line != ".":
            reader.index -= 1
            planner["progress_properties"] = parse_properties(reader, reader.count("progress properties for each run"))
            for _ in range(reader.count("runs")):
                samples = []
                for sample in reader.next().split(";"):
                    if not sample.strip():
                        continue
                    values = sample.split(",")
                    if values and values[-1].strip() == "":
                        values = values[:-1]
                    if len(values) != len(planner["progress_properties"]):
                        raise reader.error("a progress sample has %d values for %d properties"
                                           % (len(values), len(planner["progress_properties"])))
                    samples.append([typed_value(v, t) for v, (_, t) in zip(values, planner["progress_properties"])])
                planner["progress"].append(samples)
            if reader.next().strip() != ".":
                raise reader.error("expected '.' after the progress data")
        log["planners"].append(planner)
    return log


def add_missing_columns(cursor, table, columns):
    cursor.execute('PRAGMA table_info("%s")' % table)
    existing = {row[1] for row in cursor.fetchall()}
    for name, sql_type in columns:
        if name not in existing:
            cursor.execute('ALTER TABLE "%s" ADD "%s" %s' % (table, name, sql_type))
            existing.add(name)


def experiment_groups(logs):
    """Logs with the same experiment name and time limit -> one experiment."""
    groups = {}
    for log in logs:
        groups.setdefault((log["name"], log["timelimit"]), []).append(log)
    limits_per_name = {}
    for name, limit in groups:
        limits_per_name.setdefault(name, set()).add(limit)
    named = []
    for (name, limit), members in groups.items():
        label = name if len(limits_per_name[name]) == 1 else "%s %gs" % (name, limit)
        named.append((label, members))
    return sorted(named, key=lambda item: item[0])


PLANNER_SPECS = "Properties of benchmarked planners:"


def merged_setup(members):
    """One experiment's setup text: the problem description of the first log (the others
    describe the same space, start and goals; only their sampled statistics differ) followed by
    every log's planner specification, instead of 23 near-copies of the problem."""
    head, marker, _ = members[0]["setup"].partition(PLANNER_SPECS)
    if not marker:
        return "".join(log["setup"] for log in members)
    specs = [log["setup"].partition(PLANNER_SPECS)[2].lstrip("\n") for log in members]
    return head + PLANNER_SPECS + "\n" + "".join(specs)


def insert_log_runs(cursor, experiment_id, log, planners):
    """Inserts the runs (and progress samples) of `planners` (entries of log["planners"]) into
    experiment `experiment_id`, adding plannerConfigs, enums and columns as needed."""
    for enum_name, descriptions in log["enums"]:
        for value, description in enumerate(descriptions):
            cursor.execute("INSERT OR IGNORE INTO enums VALUES (?,?,?)", (enum_name, value, description))
    for planner in planners:
        cursor.execute("SELECT id FROM plannerConfigs WHERE name=? AND settings=?",
                       (planner["name"], planner["settings"]))
        row = cursor.fetchone()
        if row is None:
            cursor.execute("INSERT INTO plannerConfigs (name, settings) VALUES (?,?)",
                           (planner["name"], planner["settings"]))
            planner_id = cursor.lastrowid
        else:
            planner_id = row[0]
        add_missing_columns(cursor, "runs", planner["properties"])
        run_columns = ["experimentid", "plannerid"] + [name for name, _ in planner["properties"]]
        insert_run = 'INSERT INTO runs (%s) VALUES (%s)' % (
            ",".join('"%s"' % c for c in run_columns), ",".join("?" * len(run_columns)))
        run_ids = []
        for run in planner["runs"]:
            cursor.execute(insert_run, [experiment_id, planner_id] + run)
            run_ids.append(cursor.lastrowid)
        if not planner["progress_properties"]:
            continue
        add_missing_columns(cursor, "progress", planner["progress_properties"])
        progress_columns = ["runid"] + [name for name, _ in planner["progress_properties"]]
        insert_progress = 'INSERT OR IGNORE INTO progress (%s) VALUES (%s)' % (
            ",".join('"%s"' % c for c in progress_columns), ",".join("?" * len(progress_columns)))
        for run_id, samples in zip(run_ids, planner["progress"]):
            for sample in samples:
                cursor.execute(insert_progress, [run_id] + sample)


@contextlib.contextmanager
def replaced_atomically(db_path, copy_existing):
    """A cursor on a temporary database beside db_path (a copy of it with copy_existing, else
    empty); when the block ends normally the changes are committed and the file replaces
    db_path, otherwise it is removed and db_path stays as it was."""
    directory = os.path.dirname(os.path.abspath(db_path))
    handle, tmp_path = tempfile.mkstemp(suffix=".db", dir=directory)
    os.close(handle)
    try:
        if copy_existing:
            shutil.copy2(db_path, tmp_path)  # with its mode (mkstemp's is 0600)
        else:
            umask = os.umask(0)
            os.umask(umask)
            os.chmod(tmp_path, 0o666 & ~umask)  # as open() would create it
        connection = sqlite3.connect(tmp_path)
        yield connection.cursor()
        connection.commit()
        connection.close()
        os.replace(tmp_path, db_path)
    except BaseException:
        if os.path.exists(tmp_path):
            os.remove(tmp_path)
        raise


def write_database(logs, db_path, library_version=None):
    """Writes a fresh database (atomically replacing db_path); returns row counts."""
    with replaced_atomically(db_path, copy_existing=False) as cursor:
        cursor.execute("PRAGMA FOREIGN_KEYS = ON")
        cursor.executescript(SCHEMA)
        for label, members in experiment_groups(logs):
            first = members[0]
            version = first["version"] or library_version or "0.0.0"
            parameters = {}
            for log in members:
                for name, sql_type, value in log["parameters"]:
                    parameters[name] = (sql_type, typed_value(value, sql_type))
            add_missing_columns(cursor, "experiments", [(n, t) for n, (t, _) in parameters.items()])
            columns = ["name", "totaltime", "timelimit", "memorylimit", "runcount", "version", "hostname",
                       "cpuinfo", "date", "seed", "setup"] + list(parameters.keys())
            values = [label, sum(log["totaltime"] for log in members), first["timelimit"], first["memorylimit"],
                      max(log["runcount"] for log in members), "%s %s" % (first["library"], version),
                      first["hostname"], first["cpuinfo"], min(log["date"] for log in members), first["seed"],
                      merged_setup(members)] + [v for _, v in parameters.values()]
            cursor.execute('INSERT INTO experiments (%s) VALUES (%s)'
                           % (",".join('"%s"' % c for c in columns), ",".join("?" * len(columns))), values)
            experiment_id = cursor.lastrowid
            for log in members:
                insert_log_runs(cursor, experiment_id, log, log["planners"])
        counts = table_counts(cursor)
    return counts


def table_counts(cursor):
    counts = {}
    for table in ("experiments", "plannerConfigs", "runs", "progress", "enums"):
        cursor.execute('SELECT COUNT(*) FROM "%s"' % table)
        counts[table] = cursor.fetchone()[0]
    return counts


def find_experiment(cursor, name, timelimit):
    """Id of the experiment of (name, timelimit): named `name`, or "name <limit>s" when the
    database holds that name with several limits (experiment_groups); None when absent."""
    cursor.execute("SELECT id FROM experiments WHERE (name=? OR name=?) AND ABS(timelimit - ?) < 1e-9",
                   (name, "%s %gs" % (name, timelimit), timelimit))
    row = cursor.fetchone()
    return None if row is None else row[0]


def delete_planner_runs(cursor, experiment_id, planner_name):
    """Deletes one planner's runs (and their progress samples) from one experiment; returns the
    sum of their solve + simplification times (s), the part of the experiment's totaltime
    they stood for as far as the database knows."""
    cursor.execute('PRAGMA table_info("runs")')
    columns = {row[1] for row in cursor.fetchall()}
    seconds = " + ".join(["0"] + ["COALESCE(r.%s, 0)" % c for c in ("time", "simplification_time") if c in columns])
    cursor.execute("SELECT r.id, %s FROM runs r JOIN plannerConfigs p ON p.id = r.plannerid "
                   "WHERE r.experimentid=? AND p.name=?" % seconds, (experiment_id, planner_name))
    rows = cursor.fetchall()
    for run_id, _ in rows:
        cursor.execute("DELETE FROM progress WHERE runid=?", (run_id,))
        cursor.execute("DELETE FROM runs WHERE id=?", (run_id,))
    return sum(t for _, t in rows)


def update_database(db_path, logs, removals=(), library_version=None):
    """Replaces, in an existing database, every planner of every log: that planner's runs in the
    log's experiment (same name and time limit) are deleted and the log's inserted; the
    experiment's runcount becomes the largest run count of its planners and its totaltime loses
    the deleted runs' times and gains the log's totaltime. A log whose experiment is missing adds
    it. `removals` (experiment name, time limit, planner name as OMPL logs it, "geometric_PRM")
    only deletes (a planner that crashed and left no log). Other planners, experiments and the
    experiments' setup text stay as they are. Atomic: db_path is replaced by an updated copy.
    Returns row counts like write_database. For a database whose logs are all at hand,
    write_database is the simpler way."""
    with replaced_atomically(db_path, copy_existing=True) as cursor:
        touched = set()
        for name, timelimit, planner_name in removals:
            experiment_id = find_experiment(cursor, name, timelimit)
            if experiment_id is None:
                continue
            removed_s = delete_planner_runs(cursor, experiment_id, planner_name)
            cursor.execute("UPDATE experiments SET totaltime = totaltime - ? WHERE id=?", (removed_s, experiment_id))
            touched.add(experiment_id)
        for log in logs:
            experiment_id = find_experiment(cursor, log["name"], log["timelimit"])
            if experiment_id is None:
                cursor.execute("SELECT name FROM experiments")
                taken = any(n == log["name"] or n.startswith(log["name"] + " ") for (n,) in cursor.fetchall())
                label = "%s %gs" % (log["name"], log["timelimit"]) if taken else log["name"]
                version = log["version"] or library_version or "0.0.0"
                cursor.execute("INSERT INTO experiments (name, totaltime, timelimit, memorylimit, runcount, version, "
                               "hostname, cpuinfo, date, seed, setup) VALUES (?,?,?,?,?,?,?,?,?,?,?)",
                               (label, 0.0, log["timelimit"], log["memorylimit"], log["runcount"],
                                "%s %s" % (log["library"], version), log["hostname"], log["cpuinfo"], log["date"],
                                log["seed"], log["setup"]))
                experiment_id = cursor.lastrowid
            removed_s = 0.0
            for planner in log["planners"]:
                removed_s += delete_planner_runs(cursor, experiment_id, planner["name"])
            insert_log_runs(cursor, experiment_id, log, log["planners"])
            cursor.execute("UPDATE experiments SET totaltime = totaltime - ? + ? WHERE id=?",
                           (removed_s, log["totaltime"], experiment_id))
            touched.add(experiment_id)
        for experiment_id in touched:
            cursor.execute("SELECT MAX(n) FROM (SELECT COUNT(*) AS n FROM runs WHERE experimentid=? GROUP BY plannerid)",
                           (experiment_id,))
            cursor.execute("UPDATE experiments SET runcount=? WHERE id=?", (cursor.fetchone()[0] or 0, experiment_id))
        # planner configurations no run refers to any more (a replaced planner's old settings)
        cursor.execute("DELETE FROM plannerConfigs WHERE id NOT IN (SELECT DISTINCT plannerid FROM runs)")
        counts = table_counts(cursor)
    return counts


def main(argv):
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("logs", nargs="+", help="OMPL benchmark .log files")
    parser.add_argument("-o", "--output", default="benchmark.db", help="database to write (replaced)")
    parser.add_argument("--update", action="store_true",
                        help="update the existing OUTPUT in place: the logs' planners replace their runs "
                             "in the logs' experiments, everything else stays (update_database)")
    parser.add_argument("--library-version", default=None,
                        help="version recorded when a log has none (Debian's OMPL 1.5 writes 'OMPL version ')")
    args = parser.parse_args(argv)
    try:
        logs = [parse_log(path) for path in args.logs]
    except (OSError, LogFormatError) as e:
        print("ompl_benchmark_db: %s" % e, file=sys.stderr)
        return 1
    if args.update:
        counts = update_database(args.output, logs, library_version=args.library_version)
    else:
        counts = write_database(logs, args.output, args.library_version)
    print("%s: %d experiments, %d planner configs, %d runs, %d progress samples"
          % (args.output, counts["experiments"], counts["plannerConfigs"], counts["runs"], counts["progress"]))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
