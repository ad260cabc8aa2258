#!/usr/bin/env python3
"""Per-class tables of an FBT completion benchmark (experiments/real/fbt-bench-*.toml).

    python3 scripts/fbt_table.py RESULTS_DIR [RESULTS_DIR ...] [--default lbo] [--check]

Reads each folder's cases.csv (FBT completion rows) and prints, per class
(the case's subject: a FAUST subject, a TOSCA class, the synthetic class)
and for every method: runs, mean relative distortion after NICP (sqrt(area)
units) and before it, after the best rigid alignment, the share of gross
failures (a part off by more than 0.2 sqrt(area) on average or at its
worst), the mean worst part (mean / worst), alpha, the correspondence error,
and how many runs the method wins against the default at the same q (paired
by case; Amberg and the floor against the default at q = 4). The floor (template left undeformed) is a row like the
others. Methods are named `<pipeline>-q<q>` (`lbo-q4`, `skeleton-q4`, ...),
`der-q<q>`, `amberg`, `template`.

With --check, the acceptance of issue 38 is printed per class: the default
<= 1.05 x LBO-only at q = 4 and 8; monotone in q; better than Der et al. and
Amberg at every q >= 2 in the mean; gross failures in at most 5 % of the
runs at q >= 4.
"""

import argparse
import collections
import csv
import math
import os
import re
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from bdt_table import mean, num  # noqa: E402  (one definition of the cell parsing)


def read(folder, pooled):
    path = os.path.join(folder, "cases.csv")
    if not os.path.isfile(path):
        sys.exit(f"{path}: no such file")
    with open(path, newline="") as fh:
        rows = [r for r in csv.DictReader(fh) if r.get("fbt_task") == "completion"]
    name = os.path.basename(os.path.normpath(folder))
    for r in rows:
        r["_group"] = name if pooled else r["source"]
    return rows



def fmt(x, d=4):
    return "—" if math.isnan(x) else f"{x:.{d}f}"


def method_q(name):
    m = re.match(r"^(.*)-q(\d+)$", name)
    return (m.group(1), int(m.group(2))) if m else (name, None)


def tables(rows, default):
    by_class = collections.defaultdict(lambda: collections.defaultdict(dict))
    for r in rows:
        if r.get("status") != "ok":
            continue
        by_class[r["_group"]][r["method"]][r["case_id"]] = r
    out = {}
    for cls, methods in sorted(by_class.items()):
        lines = []
        lines.append(
            "| method | runs | distortion | before NICP | rigid-aligned | gross failures | worst part mean / worst | alpha | corr. error | wins vs default |"
        )
        lines.append("|---|---|---|---|---|---|---|---|---|---|")

        def key(name):
            fam, q = method_q(name)
            order = {"default": 0, default: 0, "lbo": 1, "skeleton": 2, "skeleton-class": 3, "skeleton-dictionary": 4,
                     "skeleton-clusters": 5, "lbo-alpha1": 6, "der": 7, "amberg": 8, "template": 9}
            return (order.get(fam, 5.5), fam, q or 0)

        for name in sorted(methods, key=key):
            runs = methods[name]
            rs = list(runs.values())
            fam, q = method_q(name)
            wins = ""
            if q is not None:
                ref = methods.get(default_method(methods, default, q), {})
            else:
                ref = methods.get(default_method(methods, default, 4), {}) if fam in ("amberg", "template") else {}
            paired = [(num(r, "rel_distortion_mean"), num(ref[c], "rel_distortion_mean"))
                      for c, r in runs.items() if c in ref]
            if paired and ref is not runs:
                wins = f"{sum(a < b for a, b in paired)} / {len(paired)}"
            lines.append(
                "| {} | {} | {} | {} | {} | {} | {} / {} | {} | {} | {} |".format(
                    name,
                    len(rs),
                    fmt(mean([num(r, "rel_distortion_mean") for r in rs])),
                    fmt(mean([num(r, "rel_distortion_mean_init") for r in rs])),
                    fmt(mean([num(r, "rel_distortion_mean_aligned") for r in rs])),
                    f"{sum(num(r, 'gross_failure') == 1 for r in rs)} / {len(rs)}",
                    fmt(mean([num(r, "worst_part_mean") for r in rs]), 3),
                    fmt(mean([num(r, "worst_part_max") for r in rs]), 3),
                    fmt(mean([num(r, "alpha") for r in rs]), 3),
                    fmt(mean([num(r, "corr_error_mean_euclidean") for r in rs])),
                    wins,
                )
            )
        out[cls] = (lines, methods)
    return out


def default_method(methods, default, q):
    """The default's row at q: `<default>-q<q>`; for `auto`, the library's
    rule without `default-q*` rows (skeleton clusters from a rig of 3 shapes,
    q >= 4 with the rig from the examples; LBO only below); else the
    LBO-only row (a pipeline that needs a rig runs LBO only at q = 1)."""
    if default == "auto":
        if f"default-q{q}" in methods:
            return f"default-q{q}"
        return f"skeleton-clusters-q{q}" if q >= 4 else f"lbo-q{q}"
    name = f"{default}-q{q}"
    return name if name in methods else f"lbo-q{q}"


def check(cls, methods, default):
    def m(name):
        rs = methods.get(name, {})
        return mean([num(r, "rel_distortion_mean") for r in rs.values()]) if rs else math.nan

    qs = sorted(q for fam, q in map(method_q, methods) if fam in (default, "lbo", "default") and q is not None)
    qs = sorted(set(qs))
    dm = {q: default_method(methods, default, q) for q in qs}
    res = []
    for q in (4, 8):
        if q in qs and f"lbo-q{q}" in methods:
            d, l = m(dm[q]), m(f"lbo-q{q}")
            res.append((f"q = {q}: default {d:.4f} <= 1.05 x LBO-only {l:.4f}", d <= 1.05 * l))
    vals = [m(dm[q]) for q in qs]
    res.append((f"monotone in q {qs}: " + " / ".join(f"{v:.4f}" for v in vals),
                all(b <= a for a, b in zip(vals, vals[1:]))))
    amb = m("amberg")
    for q in qs:
        if q < 2:
            continue
        d, der = m(dm[q]), m(f"der-q{q}")
        if not math.isnan(der):
            res.append((f"q = {q}: default {d:.4f} < Der et al. {der:.4f}", d < der))
        if not math.isnan(amb):
            res.append((f"q = {q}: default {d:.4f} < Amberg {amb:.4f}", d < amb))
    runs = [r for q in qs if q >= 4 for r in methods.get(dm[q], {}).values()]
    if runs:
        g = sum(num(r, "gross_failure") == 1 for r in runs)
        res.append((f"gross failures at q >= 4: {g} / {len(runs)} = {100 * g / len(runs):.1f} %",
                    g <= 0.05 * len(runs)))
    return res


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("folders", nargs="+")
    ap.add_argument("--default", default="auto",
                    help="the default's method family: auto (default-q* rows, else the library's rule), lbo, ...")
    ap.add_argument("--check", action="store_true", help="print the acceptance of issue 38 per class")
    ap.add_argument("--pooled", action="store_true", help="one table per results folder (all its classes) instead of per class")
    ap.add_argument("--methods", help="comma-separated methods to show (default: all)")
    a = ap.parse_args(argv)
    rows = [r for f in a.folders for r in read(f, a.pooled)]
    if not rows:
        sys.exit("no FBT completion rows")
    failed = 0
    keep = set(a.methods.split(",")) if a.methods else None
    for cls, (lines, methods) in tables(rows, a.default).items():
        print(f"\n### {'' if a.pooled else 'class '}{cls}\n")
        print("\n".join(ln for ln in lines if keep is None or not ln.startswith("| ") or
                        ln.split(" | ")[0][2:] in keep or ln.startswith("| method") ))
        if a.check:
            print()
            for text, ok in check(cls, methods, a.default):
                print(f"- {'holds' if ok else 'FAILS'}: {text}")
                failed += not ok
    if a.check:
        print(f"\n{failed} acceptance item(s) fail")


if __name__ == "__main__":
    main()
