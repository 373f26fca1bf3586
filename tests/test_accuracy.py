"""The speed/accuracy report (flexclear accuracy --quick) and what it must show: errors against
the converged reference fall with dt at the first order expected of fixed-step Newmark across a
contact entry (the spring-dashpot force jumps there), and the files are written."""

import json
import math

from flexclear.cli import main


def test_accuracy_quick_report(tmp_path, capsys):
    assert main(["accuracy", "--quick", "--out", str(tmp_path)]) == 0
    assert (tmp_path / "pareto.png").stat().st_size > 10_000
    text = (tmp_path / "accuracy.md").read_text()
    assert "## Recommendation" in text and "| 1% |" in text
    cases = [
        c for c in json.loads((tmp_path / "cases.json").read_text()) if c["coupling"] == "modified, iterated"
    ]
    err = {c["dt"]: c["errors"]["peak_force"] for c in cases}
    # peak force error: first order (0.6..1.5 allows for the entry timing), falling to below 1 %
    order = math.log(err[3e-6] / err[3e-7]) / math.log(10)
    assert 0.6 < order < 1.5, err
    assert err[3e-7] < 0.01
    assert all(c["cpu"] > 0 and not c["diverged"] for c in cases)
