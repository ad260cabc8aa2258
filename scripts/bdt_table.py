#!/usr/bin/env python3
"""Markdown tables of a transfer experiment's results (standard library only).

    scripts/bdt_table.py RESULTS_DIR [--floor identity] [--per-case] [--cases-of METHOD ...]

Reads RESULTS_DIR/cases.csv (written by `deformlab run`) and prints, per
method (in config order):

* n: cases with a result (failures counted apart);
* key points: mean count;
* raw / rigid: mean per-vertex error to the ground truth in √area(B)
  units, as is and after the best rigid alignment of each result onto its
  truth (`err_mean_area`, `err_mean_area_rigid`);
* within 0.02 / 0.05: mean fraction of vertices within that error (raw,
  and rigid);
* beats floor: cases (× methods, with --by-group) whose raw error is below the floor method's (the
  target left unchanged) on the same case;
* worst / floor: the largest ratio of the method's raw error to the
  floor's over the cases (above 1: a case where leaving B unchanged is
  better).

--methods M ... limits the overall table to those rows (in that order).
With --per-case, one more table: raw / rigid error of every case for the
methods named by --cases-of (default: all). With --by-pose, the means of
every method per deformed pose (the `poses` column): raw / rigid.
"""

import argparse
import collections
import csv
import math
import sys
from pathlib import Path


def load(path):
    rows = list(csv.DictReader(open(path, newline="")))
    if not rows:
        sys.exit(f"{path}: no rows")
    for col in ("case_id", "method", "status", "err_mean_area", "err_mean_area_rigid"):
        if col not in rows[0]:
            sys.exit(f"{path}: no column {col!r} (not a transfer experiment with a ground truth?)")
    return rows


def num(r, key):
    v = r.get(key, "")
    try:
        return float(v)
    except ValueError:
        return math.nan


def mean(xs):
    xs = [x for x in xs if not math.isnan(x)]
    return sum(xs) / len(xs) if xs else math.nan


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("results", type=Path)
    ap.add_argument("--floor", default="identity", help="the floor method's name (default identity)")
    ap.add_argument("--per-case", action="store_true")
    ap.add_argument("--cases-of", nargs="*", default=None)
    ap.add_argument("--by-pose", action="store_true")
    ap.add_argument("--methods", nargs="*", default=None, help="rows of the overall table (default: all, in config order)")
    ap.add_argument("--only-by-pose", action="store_true", help="with --by-pose: that table alone")
    ap.add_argument("--only-per-case", action="store_true", help="with --per-case: that table alone")
    ap.add_argument("--by-group", action="store_true",
                    help="one row per method group (the configs' `group`; methods without one are their own)")
    a = ap.parse_args()
    if a.by_group and (a.per_case or a.by_pose):
        sys.exit("--by-group is for the overall table only")
    rows = load(a.results / "cases.csv")
    methods = []
    by = collections.defaultdict(dict)
    floor = {}
    for r in rows:
        if r["method"] == a.floor:
            floor[r["case_id"]] = r
        name = (r.get("group") or r["method"]) if a.by_group else r["method"]
        if name not in by:
            methods.append(name)
        by[name][(r["case_id"], r["method"]) if a.by_group else r["case_id"]] = r
    if not floor:
        sys.exit(f"no floor method {a.floor!r} in {a.results}/cases.csv (methods: {', '.join(methods)})")
    n_cases = len({r["case_id"] for r in rows})
    only = (a.only_by_pose and a.by_pose) or (a.only_per_case and a.per_case)
    if not only:
        overall(a, rows, methods, by, floor, n_cases)
    if a.by_pose:
        by_pose(rows, methods, by, header=not only)
    if a.per_case:
        per_case(a, rows, methods, by, header=not only)


def overall(a, rows, methods, by, floor, n_cases):
    if a.methods:
        for m in a.methods:
            if m not in by:
                sys.exit(f"--methods: no method {m!r} (methods: {', '.join(methods)})")
        methods = a.methods
    print(f"{n_cases} cases; errors in √area(B) units; floor = `{a.floor}` (B unchanged).\n")
    print("| method | n | failed | key points | raw | rigid | within 0.02 | within 0.05 | within 0.02 rigid | within 0.05 rigid | beats floor | worst / floor |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    for m in methods:
        cs = by[m]
        ok = [r for r in cs.values() if r["status"] == "ok"]
        kp = mean([num(r, "n_keypoints") for r in ok])
        ratios = [
            num(r, "err_mean_area") / num(floor[r["case_id"]], "err_mean_area")
            for r in cs.values()
            if r["status"] == "ok" and r["case_id"] in floor and floor[r["case_id"]]["status"] == "ok"
        ]
        beats = sum(1 for x in ratios if x < 1.0)
        worst = max(ratios) if ratios else math.nan
        kps = "–" if math.isnan(kp) or kp == 0 else f"{kp:.2f}"
        print(
            f"| {m} | {len(ok)} | {len(cs) - len(ok)} | {kps} | {mean([num(r, 'err_mean_area') for r in ok]):.4f} "
            f"| {mean([num(r, 'err_mean_area_rigid') for r in ok]):.4f} "
            f"| {mean([num(r, 'within_002_area') for r in ok]):.3f} | {mean([num(r, 'within_005_area') for r in ok]):.3f} "
            f"| {mean([num(r, 'within_002_area_rigid') for r in ok]):.3f} | {mean([num(r, 'within_005_area_rigid') for r in ok]):.3f} "
            f"| {beats} / {len(ratios)} | {worst:.3f} |"
        )


def by_pose(rows, methods, by, header):
    poses = sorted({r["poses"] for r in rows}, key=lambda p: [int(x) if x.isdigit() else x for x in p.split(";")])
    if header:
        print("\nMean per deformed pose, raw / rigid:\n")
    print("| method | " + " | ".join(f"pose {p}" for p in poses) + " |")
    print("|---|" + "---|" * len(poses))
    for m in methods:
        cells = []
        for p in poses:
            ok = [r for r in by[m].values() if r["poses"] == p and r["status"] == "ok"]
            cells.append(
                f"{mean([num(r, 'err_mean_area') for r in ok]):.3f} / {mean([num(r, 'err_mean_area_rigid') for r in ok]):.3f}"
            )
        print(f"| {m} | " + " | ".join(cells) + " |")


def per_case(a, rows, methods, by, header):
    show = a.cases_of if a.cases_of else methods
    for m in show:
        if m not in by:
            sys.exit(f"--cases-of: no method {m!r} (methods: {', '.join(methods)})")
    if header:
        print("\nPer case, raw / rigid:\n")
    print("| case | " + " | ".join(show) + " |")
    print("|---|" + "---|" * len(show))
    for c in sorted({r["case_id"] for r in rows}, key=lambda c: int(by[methods[0]][c]["case"]) if c in by[methods[0]] else 0):
        cells = []
        for m in show:
            r = by[m].get(c)
            if r is None or r["status"] != "ok":
                cells.append("failed" if r is not None else "–")
            else:
                cells.append(f"{num(r, 'err_mean_area'):.4f} / {num(r, 'err_mean_area_rigid'):.4f}")
        print(f"| {c} | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
