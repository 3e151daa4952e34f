"""The README's Python example runs as written."""

import os
import re

from conftest import FE_SWEEP, REPO


def test_readme_example_runs(tmp_path, capsys):
    text = (REPO / "README.md").read_text()
    blocks = re.findall(r"```python\n(.*?)```", text, re.S)
    assert blocks, "the README has no Python example"
    data = tmp_path / "python/tests/data"
    data.mkdir(parents=True)
    (data / FE_SWEEP.name).symlink_to(FE_SWEEP)
    cwd = os.getcwd()
    os.chdir(tmp_path)
    try:
        exec(compile(blocks[0], "README.md", "exec"), {"__name__": "__readme__"})
    finally:
        os.chdir(cwd)
    assert (tmp_path / "gonio-tour/fe-fit.png").stat().st_size > 10_000
    assert "three-component" in capsys.readouterr().out
