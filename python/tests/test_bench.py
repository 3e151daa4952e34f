"""The evaluation benchmark (python/bench/bench_eval.py) runs and reports its ratios;
the timings themselves are the benchmark's business, never a test's."""

import importlib.util
import re

from conftest import REPO


def test_the_eval_benchmark_runs_and_reports_ratios(capsys):
    spec = importlib.util.spec_from_file_location("bench_eval", REPO / "python" / "bench" / "bench_eval.py")
    bench = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(bench)
    bench.main(repeats=1)
    out = capsys.readouterr().out
    ratios = [float(r) for r in re.findall(r"ratio\s+([0-9.]+)", out)]
    assert len(ratios) == 8 and all(r > 0 for r in ratios), out
