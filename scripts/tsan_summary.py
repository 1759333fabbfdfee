#!/usr/bin/python3
"""Reads ThreadSanitizer logs (TSAN_OPTIONS log_path=DIR/tsan writes DIR/tsan.<pid>) and prints
the distinct reports: a report is keyed by its kind and the top fast_grasp frame of each of its
stacks (the access, the previous access, a mutex's stacks), so the same race seen a thousand
times across frames and processes counts once. A frame is fast_grasp's when its module is one of
our libraries (libfast_grasp_*) or executables (scene_camera, the test_* gtests). Reports with no such frame are
listed apart: they are inside Debian's libraries and go to test/tsan.supp with a reason, never
the ones with a fast_grasp frame.
GCC's runtime leaves the frames of our dlopen'ed libraries unnamed (`<null> <null>
(libfast_grasp_nodelets.so+0x...)`) even with an external symbolizer, so they are named here
with llvm-symbolizer (else addr2line) against the libraries in --lib-dir.
Usage: tsan_summary.py [--details] [--lib-dir DIR ...] DIR [DIR ...]
(exit 0; prints "reports: N fast_grasp, M other")"""
import glob
import os
import re
import shutil
import subprocess
import sys

FRAME = re.compile(r"^\s+#(\d+) (.*?) (\S+?)(?::(\d+))?(?::\d+)? \((\S+?)\+0x[0-9a-f]+\)\s*$")
# boost control blocks, and the std ones of clouds: every cloud a nodelet publishes is shared with
# roscpp through a boost pointer whose deleter holds the std one (nodelets/shared_cloud.h), so its
# last std owner can go right after roscpp's uninstrumented boost decrement.
REFCOUNT = re.compile(r"sp_counted_base::release|sp_counted_impl_p\w*<.*>::(dispose|~sp_counted_impl_p)|sp_ms_deleter|"
                      r"std::_Sp_counted_(ptr_inplace|deleter)<pcl::PointCloud<")
# The same frames when llvm-symbolizer names them short ("~sp_counted_impl_pd", "dispose"): by file.
REFCOUNT_FILES = re.compile(r"^(sp_counted_impl|sp_counted_base\w*|make_shared_object)\.hpp(:|$)")
FREES = re.compile(r"^(operator delete|free$|pthread_mutex_destroy$|pthread_cond_destroy$)")
OURS = re.compile(r"^(libfast_grasp_\w+\.so|scene_camera|test_\w+)$")


UNNAMED = re.compile(r"<null> <null> \(((?:libfast_grasp_\w+\.so|scene_camera|test_\w+))\+(0x[0-9a-f]+)\)")


def symbolize(texts, lib_dirs):
    """Names the unnamed frames of our modules in every text; returns the new texts."""
    wanted = {}
    for text in texts:
        for module, offset in UNNAMED.findall(text):
            wanted.setdefault(module, set()).add(offset)
    names = {}
    tool = shutil.which("llvm-symbolizer")
    for module, offsets in wanted.items():
        path = next((os.path.join(d, module) for d in lib_dirs if os.path.isfile(os.path.join(d, module))), None)
        if not path:
            continue
        ordered = sorted(offsets)
        # a return address points after the call: look up the call instruction (offset - 1)
        queries = ["0x%x" % (int(o, 16) - 1) for o in ordered]
        if tool:
            out = subprocess.run([tool, "--obj=" + path, "--inlining=false", "--functions=linkage", "--demangle"],
                                 input="\n".join(queries) + "\n", capture_output=True, text=True).stdout
            blocks = [b.splitlines() for b in out.strip("\n").split("\n\n")]
        else:
            out = subprocess.run(["addr2line", "-f", "-C", "-e", path] + queries, capture_output=True, text=True).stdout
            lines = out.splitlines()
            blocks = [lines[i:i + 2] for i in range(0, len(lines), 2)]
        for offset, block in zip(ordered, blocks):
            if len(block) >= 2:
                location = re.sub(r":(\d+):\d+$", r":\1", block[1])
                names[(module, offset)] = "%s %s" % (block[0], location)
    return [UNNAMED.sub(lambda m: "%s (%s+%s)" % (names.get((m.group(1), m.group(2)), "<null> <null>"), m.group(1), m.group(2)), t)
            for t in texts]


def split_reports(text):
    blocks = text.split("==================\n")
    for block in blocks:
        if "WARNING: ThreadSanitizer:" in block or "ERROR: ThreadSanitizer:" in block:
            yield block


def parse(block):
    kind = re.search(r"(?:WARNING|ERROR): ThreadSanitizer: (.*?)(?: \(pid=\d+\))?\n", block).group(1)
    # Only the stacks of the accesses / lock acquisitions: not where a thread was created or
    # a heap block allocated (those name our onInit for every race inside a worker thread).
    stacks, current, section = [], None, ""
    for line in block.splitlines():
        if line.startswith("  ") and not line.startswith("    "):
            section = line
        m = FRAME.match(line)
        if m:
            if m.group(1) == "0":
                current = []
                if "created by" not in section and "Location is" not in section:
                    stacks.append(current)
            module = os.path.basename(m.group(5))
            location = os.path.basename(m.group(3)) + (":" + m.group(4) if m.group(4) else "")
            current.append((m.group(2), location, module))
    # An access that destroys or frees memory because a boost reference count reached zero:
    # roscpp's and nodelet's counts are decremented in uninstrumented code, so TSan misses the
    # ordering the atomic count gives, and reports the free against the last use in another thread.
    # The same when Debian's code itself frees or destroys (frame 1 not ours: a message buffer,
    # a ros::Publication, a timer's mutex when its last boost::shared_ptr goes).
    refcount_free = any(
        (any(REFCOUNT.search(f[0]) or REFCOUNT_FILES.match(f[1]) for f in stack[:12])
         and not stack[0][0].startswith("fast_grasp::")) or
        (FREES.match(stack[0][0]) and len(stack) > 1 and not OURS.match(stack[1][2]))
        for stack in stacks[:2])
    if kind.startswith("lock-order-inversion") or kind.startswith("unlock of"):
        # whose locks: the caller of pthread_mutex_lock (frame 1). Our frames further down only
        # called into roscpp / log4cxx, whose own mutexes form the cycle.
        stacks = [stack[1:2] if len(stack) > 1 else stack for stack in stacks]
    tops = []
    for stack in stacks:
        ours = [f for f in stack if OURS.match(f[2])]
        tops.append("%s %s" % (ours[0][0], ours[0][1]) if ours else None)
    summary = re.search(r"SUMMARY: ThreadSanitizer: (.*)", block)
    return kind, tops, summary.group(1) if summary else kind, refcount_free


def main(argv):
    details = "--details" in argv
    lib_dirs, dirs, args = [], [], list(argv)
    while args:
        a = args.pop(0)
        if a == "--lib-dir" and args:
            lib_dirs.append(args.pop(0))
        elif a != "--details":
            dirs.append(a)
    ours, refcount, other = {}, {}, {}
    paths = [p for d in dirs for p in sorted(glob.glob(os.path.join(d, "tsan.*")))]
    texts = []
    for path in paths:
        with open(path, errors="replace") as f:
            texts.append(f.read())
    texts = symbolize(texts, lib_dirs)
    for path, text in zip(paths, texts):
        if True:
            for block in split_reports(text):
                kind, tops, summary, refcount_free = parse(block)
                named = [t for t in tops if t]
                if refcount_free:
                    key = (kind, tuple(named[:2]) or summary)
                    entry = refcount.setdefault(key, [0, path, block])
                elif named:
                    # the access pair (first two stacks) decides; thread-creation stacks follow
                    key = (kind, tuple(named[:2]))
                    entry = ours.setdefault(key, [0, path, block])
                else:
                    key = (kind, summary)
                    entry = other.setdefault(key, [0, path, block])
                entry[0] += 1
    for title, table in (("fast_grasp", ours), ("freed at a reference count drop in uninstrumented code", refcount),
                         ("inside Debian's libraries", other)):
        for (kind, where), (count, path, block) in sorted(table.items(), key=lambda kv: -kv[1][0]):
            where_text = " | ".join(where) if isinstance(where, tuple) else where
            print("  [%s] %s x%d: %s   (first: %s)" % (title, kind, count, where_text, path))
            if details:
                print(block)
    print("reports: %d fast_grasp, %d refcount-free, %d other" % (len(ours), len(refcount), len(other)))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
