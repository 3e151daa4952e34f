"""Fits the simulated iron sample, plots its curves and renders it in Mitsuba 3 into
docs/ (python-fe-fit.png, python-fe-sphere.png). Run from the repository root."""

import pathlib
import re
import shutil

import gonio
import gonio.mitsuba as gm

root = pathlib.Path(__file__).resolve().parents[2]
# The README's example draws the curves.
code = re.search(r"```python\n(.*?)```", (root / "README.md").read_text(), re.S).group(1)
exec(compile(code, "README.md", "exec"), {"__name__": "__readme__"})
shutil.move("fe-fit.png", root / "docs/python-fe-fit.png")
model = gonio.fit(str(root / "python/tests/data/fe-0.115.csv")).model()
gm.render_sphere(model, root / "docs/python-fe-sphere.png", resolution=128, spp=4)
