"""The README's Python example runs as written."""

from conftest import REPO


def test_readme_python_example_runs(capsys):
    text = (REPO / "README.md").read_text()
    block = text.split("```python\n", 1)[1].split("```", 1)[0]
    assert 5 <= len(block.strip().splitlines()) <= 12, "the README's example is about ten lines"
    exec(compile(block, "README.md", "exec"), {})
    out = capsys.readouterr().out
    assert out.strip(), "the example prints its results"
