#!/usr/bin/python3
"""Every key of config/*.yaml, config/grippers/*.yaml and config/robots/*.yaml (sections and
leaves; not the *_home_pose.yaml files, whose keys are the URDF's joint names) is documented:
it appears in backticks (`key`, or as `section.key` / `key:`) in a page of docs/parameters/."""
import glob
import os
import re
import sys
import unittest

import yaml

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")


def keys_of(node, prefix=()):
    if isinstance(node, dict):
        for key, value in node.items():
            yield prefix + (str(key),)
            yield from keys_of(value, prefix + (str(key),))


def documented_names():
    text = "\n".join(open(p).read() for p in glob.glob(os.path.join(ROOT, "docs", "parameters", "*.md")))
    text = re.sub(r"```.*?```", "", text, flags=re.S)  # code blocks would shift the backtick pairs
    names = set()
    for quoted in re.findall(r"`([^`]+)`", text):
        # `a.b.c`, `key: value`, `~key`, `key=...` all name key(s)
        for part in re.split(r"[\s.:=~/,()\[\]]+", quoted):
            if part:
                names.add(part)
    return names


class ParameterDocsTest(unittest.TestCase):
    def test_every_config_key_is_documented(self):
        names = documented_names()
        self.assertTrue(names, "no docs/parameters/*.md page")
        files = sorted(glob.glob(os.path.join(ROOT, "config", "*.yaml")) +
                       glob.glob(os.path.join(ROOT, "config", "grippers", "*.yaml")) +
                       [p for p in glob.glob(os.path.join(ROOT, "config", "robots", "*.yaml"))
                        if not p.endswith("_home_pose.yaml")])
        self.assertTrue(files)
        for path in files:
            with open(path) as f:
                data = yaml.safe_load(f)
            missing = sorted({".".join(k) for k in keys_of(data) if k[-1] not in names})
            with self.subTest(config=os.path.relpath(path, ROOT)):
                self.assertEqual(missing, [], "%s: keys not documented in docs/parameters/: %s"
                                 % (os.path.relpath(path, ROOT), ", ".join(missing)))


if __name__ == "__main__":
    import pyunit_main
    pyunit_main.run("parameter_docs", ParameterDocsTest, sys.argv[1:])
