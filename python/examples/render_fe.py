"""Fits the simulated iron sample, plots its curves and renders it in Mitsuba 3 into
docs/ (python-fe-fit.png, python-fe-sphere.png). Run from the repository root.
The rendering is of the exported plugin directory (what `gonio fit --export
mitsuba=DIR` writes), at the display scale since the fit is in relative units.
Needs matplotlib and Mitsuba 3: pip install './python[examples,mitsuba]'."""

import pathlib
import re
import shutil
import subprocess
import sys
import tempfile

import gonio
import gonio.mitsuba as gm

root = pathlib.Path(__file__).resolve().parents[2]
# The README's example draws the curves.
code = re.search(r"```python\n(.*?)```", (root / "README.md").read_text(), re.S).group(1)
exec(compile(code, "README.md", "exec"), {"__name__": "__readme__"})
shutil.move("fe-fit.png", root / "docs/python-fe-fit.png")
with tempfile.TemporaryDirectory() as tmp:
    out = pathlib.Path(tmp) / "fe"
    gonio.fit(str(root / "python/tests/data/fe-0.115.csv")).export_mitsuba(out)
    variant = "llvm_ad_rgb" if gm.llvm_available() else "scalar_rgb"
    subprocess.run([sys.executable, str(out / "gonio_bsdf.py"), str(root / "docs/python-fe-sphere.png"),
                    "--res", "160", "--spp", "16", "--variant", variant], check=True)
