"""The generated tables of docs/*.md are what their scripts print from the
committed results (scripts/gen_docs.py --check), and the check can fail."""

import shutil
import subprocess
import sys

from conftest import REPO


def _check(root):
    return subprocess.run([sys.executable, str(root / "scripts" / "gen_docs.py"), "--check"],
                          cwd=root, capture_output=True, text=True, timeout=300)


def test_docs_generated_blocks_match_the_results():
    r = _check(REPO)
    assert r.returncode == 0, r.stdout + r.stderr
    assert "generated block(s) checked" in r.stdout and not r.stdout.startswith("0 ")


def test_a_stale_block_is_reported(tmp_path):
    root = tmp_path / "repo"
    shutil.copytree(REPO / "scripts", root / "scripts")
    shutil.copytree(REPO / "docs", root / "docs")
    shutil.copytree(REPO / "results" / "real", root / "results" / "real")
    page = root / "docs" / "bdt-faust.md"
    page.write_text(page.read_text().replace("| default | 40 |", "| default | 41 |", 1))
    r = _check(root)
    assert r.returncode == 1 and "bdt-faust.md" in r.stdout, r.stdout + r.stderr
