#!/usr/bin/env python3
"""Regenerate the generated blocks of docs/*.md from the committed results.

A generated block is written in a page as

    <!-- generated: scripts/bdt_table.py results/real/bdt-faust --per-case -->
    ...output of that command...
    <!-- end generated -->

and holds exactly what the command prints when run from the repository root
(only scripts under scripts/ can be named, run with this Python).

    scripts/gen_docs.py           # rewrite the blocks in place
    scripts/gen_docs.py --check   # exit 1, naming the page and the command,
                                  # when a block differs from its command's output

The tests run --check, so a change to the results or the scripts without
regenerating the docs fails there.
"""

import argparse
import re
import shlex
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
BLOCK = re.compile(r"(<!-- generated: (.+?) -->\n)(.*?)(<!-- end generated -->)", re.S)


def run(cmd):
    args = shlex.split(cmd)
    if not args or not args[0].startswith("scripts/") or ".." in args[0]:
        sys.exit(f"generated block: {cmd!r} does not name a script under scripts/")
    r = subprocess.run([sys.executable, str(ROOT / args[0]), *args[1:]], cwd=ROOT,
                       capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit(f"generated block: {cmd!r} failed:\n{r.stderr}")
    out = r.stdout
    return out if out.endswith("\n") else out + "\n"


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--check", action="store_true")
    a = ap.parse_args()
    stale = []
    blocks = 0
    for page in sorted((ROOT / "docs").glob("*.md")):
        text = page.read_text()

        def repl(m):
            nonlocal blocks
            blocks += 1
            want = run(m.group(2))
            if m.group(3) != want:
                stale.append(f"{page.relative_to(ROOT)}: {m.group(2)}")
            return m.group(1) + want + m.group(4)

        new = BLOCK.sub(repl, text)
        if not a.check and new != text:
            page.write_text(new)
    if a.check and stale:
        print("stale generated blocks (run scripts/gen_docs.py):", *stale, sep="\n  ")
        sys.exit(1)
    print(f"{blocks} generated block(s) {'checked' if a.check else 'written'}")


if __name__ == "__main__":
    main()
