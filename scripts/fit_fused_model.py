#!/usr/bin/env python3
"""Fits the fused planner's success model to physics outcomes and writes it into
config/grasp_planners.yaml (the block between `# BEGIN fitted model` and `# END fitted model`).

Input: trials.csv files of scripts/evaluate_grasps_physics.py run on the TRAINING objects with
`--planners fused --pool 100` and a fused max_grasps of 100 (every pooled candidate simulated,
with its features f_*). Label: the grasp held and touched nothing before closing. Model: L2-
regularised logistic regression (Newton steps), the one the C++ side scores with
(grasp_features.h). Printed: per-scene top-1 success of the fitted ranking, in-sample and
leave-one-object-out, beside the pool's ceiling (some candidate held).

    PY="$(bash scripts/setup_venv.sh)"
    "$PY" scripts/evaluate_grasps_physics.py --split train --planners fused --pool 100 --poses 6 \\
        --params /tmp/params_pool.yaml --out-dir bench_out/pool_train
    "$PY" scripts/fit_fused_model.py bench_out/pool_train/trials.csv [--write]
"""
import argparse
import csv
import os
import re
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
CONFIG = os.path.join(ROOT, "config/grasp_planners.yaml")


def load(paths, label="clean"):
    rows = []
    for run, path in enumerate(paths):
        with open(path) as f:
            rows += [dict(r, run=run) for r in csv.DictReader(f) if r.get("planner") == "fused"
                     and r.get("status") == "ok" and r.get("unstable") != "True"]
    if not rows:
        sys.exit("no fused candidate trials in %s" % ", ".join(paths))
    names = sorted({k[2:] for r in rows for k in r if k.startswith("f_")})
    x = np.array([[float(r.get("f_" + n) or 0.0) for n in names] for r in rows])
    # clean: held and touched nothing before closing (single objects); success: held (clutter,
    # where brushing a neighbour on the way in is part of the task)
    y = np.array([1.0 if r["success"] == "True" and (label == "success" or r["unexpected_contact"] != "True")
                  else 0.0 for r in rows])
    # a scene is one view of one run: the same pose in two runs (other candidates) is two scenes
    scene = ["%s/%s/%s/%s/%s" % (r["run"], r["object"], r["pose"], r["view"], r["gripper"]) for r in rows]
    objects = [r["object"] for r in rows]
    return names, x, y, scene, objects


def config_model():
    """(bias, {feature: weight}) of the model in config/grasp_planners.yaml."""
    with open(CONFIG) as f:
        block = re.search(r"  # BEGIN fitted model.*?  # END fitted model", f.read(), flags=re.S)
    if not block:
        sys.exit("%s: no BEGIN/END fitted model block" % CONFIG)
    bias = float(re.search(r"\n    bias: *([-+0-9.eE]+)", block.group(0)).group(1))
    weights = {m.group(1): float(m.group(2))
               for m in re.finditer(r"\n      ([a-z_]+): *([-+0-9.eE]+)", block.group(0))}
    return bias, weights


def fit(x, y, scene, l2=0.001, iterations=2000, anchor=None):
    """Ranking, then calibration. The score is fitted so that within each scene the candidates
    that held come first (softmax over the scene's candidates, maximising the probability of
    picking one that held: per-candidate logistic regression was worse at the top-1 choice, as
    scenes with many easy candidates dominate it); a 1-D logistic fit of the outcome on that
    score then turns it into a success probability. Features standardised inside, weights
    returned raw. With `anchor` (raw weights of a model fitted before, e.g. on single objects
    whose trials are not at hand), the L2 term pulls towards that model's ranking (scaled to
    this data's best temperature) instead of towards zero: new data corrects it where it has
    something to say and leaves it alone elsewhere."""
    mean, std = x.mean(axis=0), x.std(axis=0)
    std[std < 1e-9] = 1.0
    z = (x - mean) / std
    groups = {}
    for i, s in enumerate(scene):
        groups.setdefault(s, []).append(i)
    # scenes where every candidate held or none did say nothing about the ranking
    informative = [np.array(g) for g in groups.values() if 0 < y[g].sum() < len(g)]
    w0 = np.zeros(z.shape[1])
    if anchor is not None:
        direction = np.asarray(anchor) * std  # the same ranking in standardised features
        scale = min(np.logspace(-3, 1, 41), key=lambda c: _ranking_nll(z, y, informative, c * direction))
        w0 = scale * direction
    w = w0.copy()
    rate = 0.5
    for _ in range(iterations):
        grad = l2 * (w - w0) * len(informative)
        for g in informative:
            s = z[g] @ w
            e = np.exp(s - s.max())
            p_all = e / e.sum()
            good = y[g] > 0.5
            p_good = e * good / (e * good).sum()
            grad += z[g].T @ (p_all - p_good)
        w -= rate * grad / max(1, len(informative))
    score = z @ w
    # Calibration: the slope from the scores centred per scene (what the ranking compares:
    # across scenes the raw score need not sort the outcomes), the offset from the mean rate.
    centred = score.copy()
    for g in groups.values():
        centred[g] -= score[g].mean()
    a, _ = _logistic_1d(centred, y)
    # bounded so the probabilities never saturate (equal 1.0s would lose the ranking)
    a = min(max(a, 1e-3), 2.0 / max(float(score.std()), 1e-9))
    rate = min(max(y.mean(), 1e-3), 1.0 - 1e-3)
    b = float(np.log(rate / (1.0 - rate))) - a * float(score.mean())
    weights = a * w / std
    bias = b - float(weights @ mean)
    return bias, weights


def _ranking_nll(z, y, informative, w):
    """Minus the log-probability, summed over scenes, that the softmax over a scene's scores
    picks a candidate that held."""
    total = 0.0
    for g in informative:
        s = z[g] @ w
        e = np.exp(s - s.max())
        total -= np.log((e * (y[g] > 0.5)).sum() / e.sum())
    return total


def _logistic_1d(s, y, iterations=50):
    """(a, b) of p = sigmoid(a s + b) by Newton steps."""
    z = np.stack([s, np.ones_like(s)], axis=1)
    w = np.array([1.0, 0.0])
    for _ in range(iterations):
        p = 1.0 / (1.0 + np.exp(-np.clip(z @ w, -30, 30)))
        ridge = np.array([1.0, 0.0])  # keeps the slope finite when the score separates the outcomes
        grad = z.T @ (p - y) + ridge * w
        hess = (z * (p * (1 - p))[:, None]).T @ z + np.diag(ridge + 1e-6)
        w -= np.linalg.solve(hess, grad)
    return w[0], w[1]


def top1(x, y, scene, bias, weights):
    """Per scene: does the candidate the model ranks first hold? (ties keep the pool order)"""
    score = bias + x @ weights
    best = {}
    for i, s in enumerate(scene):
        if s not in best or score[i] > score[best[s]] + 1e-12:
            best[s] = i
    return np.mean([y[i] for i in best.values()]), len(best)


def ceiling(y, scene):
    held = {}
    for i, s in enumerate(scene):
        held[s] = max(held.get(s, 0.0), y[i])
    return np.mean(list(held.values()))


def write_block(names, bias, weights, provenance):
    with open(CONFIG) as f:
        text = f.read()
    lines = ["  # BEGIN fitted model (scripts/fit_fused_model.py)", "  model:",
             '    fitted_on: "%s"' % provenance, "    bias: %.6g" % bias, "    weights:"]
    lines += ["      %s: %.6g" % (n, w) for n, w in zip(names, weights)]
    lines.append("  # END fitted model")
    new, count = re.subn(r"  # BEGIN fitted model.*?  # END fitted model", "\n".join(lines), text, flags=re.S)
    if count != 1:
        sys.exit("%s: no BEGIN/END fitted model block" % CONFIG)
    with open(CONFIG, "w") as f:
        f.write(new)


def main(argv):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], epilog=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("trials", nargs="+", help="trials.csv of fused pool runs on the training objects")
    p.add_argument("--l2", type=float, default=0.001)
    p.add_argument("--write", action="store_true", help="write the model into config/grasp_planners.yaml")
    p.add_argument("--anchor", action="store_true",
                   help="regularise towards the model now in config/grasp_planners.yaml instead of towards zero "
                        "(refit on new trials, e.g. scripts/evaluate_clutter_physics.py --pool, without the old ones)")
    p.add_argument("--label", default="clean", choices=["clean", "success"],
                   help="what counts as held: clean (held, nothing touched before closing) or success (held)")
    args = p.parse_args(argv)
    names, x, y, scene, objects = load(args.trials, args.label)
    anchor = None
    if args.anchor:
        _, old_weights = config_model()
        anchor = [old_weights.get(n, 0.0) for n in names]
        print("anchored at the model in %s (%d of %d features weighted there)"
              % (CONFIG, sum(n in old_weights for n in names), len(names)))
    bias, weights = fit(x, y, scene, args.l2, anchor=anchor)
    in_sample, scenes = top1(x, y, scene, bias, weights)
    pool_order, _ = top1(x, y, scene, 0.0, np.zeros(len(names)))
    if anchor is not None:
        old_bias, _ = config_model()
        current, _ = top1(x, y, scene, old_bias, np.asarray(anchor))
        print("top-1 success of the model now in the config: %.0f %%" % (100 * current))
    # leave one object out: the ranking on objects the model never saw
    held = []
    for obj in sorted(set(objects)):
        train = np.array([o != obj for o in objects])
        b, w = fit(x[train], y[train], [s for s, k in zip(scene, train) if k], args.l2, anchor=anchor)
        idx = np.where(~train)[0]
        acc, n = top1(x[idx], y[idx], [scene[i] for i in idx], b, w)
        held += [acc] * n
    print("%d candidates in %d scenes of %d objects, %.0f %% of candidates held" %
          (len(y), scenes, len(set(objects)), 100.0 * y.mean()))
    print("top-1 success: pool order %.0f %%, fitted in-sample %.0f %%, leave-one-object-out %.0f %%, "
          "ceiling (some candidate held) %.0f %%" % (100 * pool_order, 100 * in_sample, 100 * np.mean(held),
                                                     100 * ceiling(y, scene)))
    for n, w in sorted(zip(names, weights), key=lambda t: -abs(t[1])):
        print("  %-24s %+.3f" % (n, w))
    print("  %-24s %+.3f" % ("bias", bias))
    if args.write:
        provenance = "%d candidates, %d training scenes (%s), leave-one-object-out top-1 %.0f %%" % (
            len(y), scenes, os.path.basename(os.path.dirname(os.path.abspath(args.trials[0]))), 100 * np.mean(held))
        write_block(names, bias, weights, provenance)
        print("wrote the model into %s" % CONFIG)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
