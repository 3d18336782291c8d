"""docs/python.md's examples run as they are, from the source directory."""
import os
import re

SOURCE = os.environ["AMBLER_SOURCE_DIR"]


def test_the_pages_examples_run(monkeypatch):
    with open(os.path.join(SOURCE, "docs", "python.md")) as f:
        blocks = re.findall(r"```python\n(.*?)```", f.read(), re.S)
    assert blocks
    monkeypatch.chdir(SOURCE)
    for block in blocks:
        exec(compile(block, "docs/python.md", "exec"), {})
