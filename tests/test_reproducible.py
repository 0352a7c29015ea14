"""Identical runs give bitwise identical results: no decision inside the solver reads the
wall clock (the kept factorisation's refactorisation choice once did, and two demo runs then
differed by up to 1.25e-11)."""
import pathlib
import subprocess
import sys

import numpy as np


def demo(out):
    subprocess.run([sys.executable, "-m", "ngcontact", "demo", "--steps", "24", "--maxh", "0.01", "--out", str(out)],
                   check=True, capture_output=True, timeout=600)
    return sorted(pathlib.Path(out, "run", "steps").glob("*.npz"))


def test_the_demo_twice_is_bitwise_the_same(tmp_path):
    """Two demo runs in two processes: every stored array of every step (state, β, records,
    Newton's residual history, the linear solver's counts) is bitwise equal; only wall times
    may differ."""
    first, second = demo(tmp_path / "a"), demo(tmp_path / "b")
    assert len(first) == len(second) == 25
    compared = 0
    for a, b in zip(first, second):
        with np.load(a) as x, np.load(b) as y:
            assert sorted(x.files) == sorted(y.files)
            for key in x.files:
                if key == "wall_s" or key.startswith("timings/"):
                    continue
                assert np.array_equal(x[key], y[key]), (a.name, key)
                compared += 1
    assert compared > 25 * 20
