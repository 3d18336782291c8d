"""docs/python.md's examples run as they are, from a directory that looks like the source directory
(its scenarios/ linked), so what they write stays out of the source tree."""
import os
import re

SOURCE = os.environ["AMBLER_SOURCE_DIR"]


def test_the_pages_examples_run(monkeypatch, tmp_path):
    with open(os.path.join(SOURCE, "docs", "python.md")) as f:
        blocks = re.findall(r"```python\n(.*?)```", f.read(), re.S)
    assert blocks
    os.symlink(os.path.join(SOURCE, "scenarios"), tmp_path / "scenarios")
    monkeypatch.chdir(tmp_path)
    for block in blocks:
        exec(compile(block, "docs/python.md", "exec"), {})
    assert (tmp_path / "runs" / "basin_mine" / "report.html").is_file()
