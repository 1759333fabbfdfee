#!/usr/bin/python3
"""Reads ThreadSanitizer logs (TSAN_OPTIONS log_path=DIR/tsan writes DIR/tsan.<pid>) and prints
the distinct reports: a report is keyed by its kind and the top fast_grasp frame of each of its
stacks (the access, the previous access, a mutex's stacks), so the same race seen a thousand
times across frames and processes counts once. A frame is fast_grasp's when its module is one of
our libraries (libfast_grasp_*) or executables (scene_camera). Reports with no such frame are
listed apart: they are inside Debian's libraries and go to test/tsan.supp with a reason, never
the ones with a fast_grasp frame.
Usage: tsan_summary.py [--details] DIR [DIR ...]    (exit 0; prints "reports: N fast_grasp, M other")"""
import glob
import os
import re
import sys

FRAME = re.compile(r"^\s+#(\d+) (.*?) (\S+?)(?::(\d+))?(?::\d+)? \((\S+?)\+0x[0-9a-f]+\)\s*$")
OURS = re.compile(r"^(libfast_grasp_\w+\.so|scene_camera)$")


def split_reports(text):
    blocks = text.split("==================\n")
    for block in blocks:
        if "WARNING: ThreadSanitizer:" in block or "ERROR: ThreadSanitizer:" in block:
            yield block


def parse(block):
    kind = re.search(r"(?:WARNING|ERROR): ThreadSanitizer: (.*?)(?: \(pid=\d+\))?\n", block).group(1)
    stacks, current = [], None
    for line in block.splitlines():
        m = FRAME.match(line)
        if m:
            if m.group(1) == "0":
                current = []
                stacks.append(current)
            module = os.path.basename(m.group(5))
            location = os.path.basename(m.group(3)) + (":" + m.group(4) if m.group(4) else "")
            current.append((m.group(2), location, module))
    tops = []
    for stack in stacks:
        ours = [f for f in stack if OURS.match(f[2])]
        tops.append("%s %s" % (ours[0][0], ours[0][1]) if ours else None)
    summary = re.search(r"SUMMARY: ThreadSanitizer: (.*)", block)
    return kind, tops, summary.group(1) if summary else kind


def main(argv):
    details = "--details" in argv
    dirs = [a for a in argv if a != "--details"]
    ours, other = {}, {}
    for d in dirs:
        for path in sorted(glob.glob(os.path.join(d, "tsan.*"))):
            with open(path, errors="replace") as f:
                text = f.read()
            for block in split_reports(text):
                kind, tops, summary = parse(block)
                named = [t for t in tops if t]
                if named:
                    # the access pair (first two stacks) decides; thread-creation stacks follow
                    key = (kind, tuple(t for t in tops[:2] if t) or tuple(named[:1]))
                    entry = ours.setdefault(key, [0, path, block])
                else:
                    key = (kind, summary)
                    entry = other.setdefault(key, [0, path, block])
                entry[0] += 1
    for title, table in (("fast_grasp", ours), ("inside Debian's libraries", other)):
        for (kind, where), (count, path, block) in sorted(table.items(), key=lambda kv: -kv[1][0]):
            where_text = " | ".join(where) if isinstance(where, tuple) else where
            print("  [%s] %s x%d: %s   (first: %s)" % (title, kind, count, where_text, path))
            if details:
                print(block)
    print("reports: %d fast_grasp, %d other" % (len(ours), len(other)))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
