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


def test_readme_is_a_way_in():
    """At most 250 lines; it opens with the fresh machine's two commands (the demo, the tests),
    has the sections a new user looks for, shows the test command .ci/run runs, and every extra
    it installs exists (the tutorials' one with JupyterLab)."""
    import tomllib
    text = README.read_text()
    assert len(text.splitlines()) <= 250, len(text.splitlines())
    first = re.search(r"```bash\n(.*?)```", text, re.S).group(1).splitlines()
    assert first == ['pip install . && python -m ngcontact demo --out results',
                     'pip install ".[test]" && python -m pytest'], first
    sections = set(re.findall(r"^## (.+)$", text, re.M))
    assert {"Install", "Quick start", "Python API", "Tutorials", "Documentation", "Development"} <= sections, sections
    development = text[text.index("## Development"):]
    command = re.search(r"```bash\n(.*?)\n```", development, re.S).group(1)
    assert command == first[1] and command in (README.parent / ".ci" / "run").read_text().splitlines()
    extras = tomllib.loads((README.parent / "pyproject.toml").read_text())["project"]["optional-dependencies"]
    named = set(re.findall(r'pip install "\.\[([a-z]+)\]"', text))          # (".[NAME]": the pattern)
    assert {"test", "docs", "notebooks"} <= named and named <= set(extras), named
    assert "jupyterlab" in extras["notebooks"] and "sphinx" in " ".join(extras["docs"])
