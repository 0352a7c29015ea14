"""The README's Python example runs as printed and its result balances."""
import pathlib
import re

import numpy as np

README = pathlib.Path(__file__).parents[1] / "README.md"


def test_readme_api_example():
    code = re.search(r"## Python API.*?```python\n(.*?)```", README.read_text(), re.S).group(1)
    scope = {}
    exec(code, scope)
    last, c = scope["last"], scope["c"]
    applied = 2e6 * 0.1                                   # pressure at t = 0.1 s times L1, N/m
    assert np.allclose(last.reaction + c.force, [0, applied], rtol=0, atol=1e-6 * applied)
    assert c.contact_area > 0 and c.max_penetration < 1e-2 * 2e-5
    assert np.all((c.beta >= 0) & (c.beta <= 1))
