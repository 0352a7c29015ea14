"""The documentation builds with Sphinx without a warning, its API reference documents the public
API from the docstrings, and its front page renders in a real browser (headless Chromium).

Needs the ``docs`` extra (``pip install ".[docs]"``; ``.ci/run`` installs it after the test run)
and Debian's chromium for the screenshot.
"""
import html
import importlib.util
import os
import pathlib
import re
import subprocess
import sys

import numpy as np
import pytest

from test_webgui import CHROMIUM, screenshot as webgui_screenshot

ROOT = pathlib.Path(__file__).parents[1]
MISSING = [name for name in ("sphinx", "myst_nb") if importlib.util.find_spec(name) is None]
pytestmark = [pytest.mark.docs,
              pytest.mark.skipif(bool(MISSING), reason=f"the docs extra is not installed (no {', '.join(MISSING)}): "
                                                       "pip install \".[docs]\"")]
needs_chromium = pytest.mark.skipif(CHROMIUM is None and not os.environ.get("CI"),
                                    reason="needs Debian's chromium (.ci/run installs it)")


@pytest.fixture(scope="module")
def site(tmp_path_factory):
    """The site built as the README says, ``python -m sphinx -W -b html docs OUT``: any warning
    fails the build."""
    out = tmp_path_factory.mktemp("docs") / "html"
    done = subprocess.run([sys.executable, "-m", "sphinx", "-W", "--keep-going", "-q", "-b", "html", "docs", str(out)],
                          cwd=ROOT, capture_output=True, text=True, timeout=900)
    assert done.returncode == 0, f"the docs build warned or failed:\n{done.stderr[-5000:]}"
    return out


def test_api_reference_documents_the_public_api(site):
    """Simulation.run (with its parameters) and every class of ``ngcontact.__all__`` have an
    entry generated from their docstrings."""
    import ngcontact
    pages = {path.name: path.read_text() for path in (site / "api").glob("*.html")}
    ids = set(re.findall(r'id="(ngcontact\.[\w.]+)"', "".join(pages.values())))
    assert "ngcontact.Simulation.run" in ids, sorted(ids)[:50]
    run = html.unescape(re.sub(r"<[^>]+>", "", pages["simulation.html"]))
    assert "max_cutbacks" in run and "Step from the current time to T" in run
    classes = [name for name in ngcontact.__all__ if isinstance(getattr(ngcontact, name), type)]
    missing = [name for name in classes if f"ngcontact.{name}" not in ids]
    assert classes and not missing, missing
    for module in ("laws", "obstacles", "adapt", "results"):            # public modules, by their place
        assert any(i.startswith(getattr(ngcontact, module).__name__ + ".") for i in ids), module


def test_tutorials_and_topic_pages_are_in_the_site(site):
    tutorials = sorted(p.stem for p in (ROOT / "tutorials").glob("*.ipynb"))
    assert tutorials and all((site / "tutorials" / f"{name}.html").exists() for name in tutorials)
    pages = sorted(p.stem for p in (ROOT / "docs").glob("*.md") if p.stem != "index")
    missing = [name for name in pages if not (site / f"{name}.html").exists()]
    assert pages and not missing, missing
    index = (site / "index.html").read_text()
    assert "api/index.html" in index and "tutorials/01_quick_start.html" in index


def screenshot(page, png, profile):
    """The page in headless Chromium (``test_webgui.screenshot``), 1000 x 800."""
    return webgui_screenshot(page, png, profile, size=(1000, 800))


def ink(image):
    """The share of pixels that are not background (darker than 0.6 in every channel: text)."""
    return float(np.mean(image.max(axis=2) < 0.6))


@needs_chromium
def test_front_page_renders_in_a_browser(site, tmp_path):
    """The built index shows text and its sidebar (dark pixels over a good part of the view, with
    the stylesheet's colours); an empty page, the control, shows none."""
    image = screenshot(site / "index.html", tmp_path / "index.png", tmp_path / "profile")
    assert image.shape[:2] == (800, 1000)
    assert ink(image) > 0.01 and image.std() > 0.05, (ink(image), image.std())
    left, right = image[:, :250], image[:, 250:]                 # the sidebar and the page both hold text
    assert ink(left) > 0.002 and ink(right) > 0.005, (ink(left), ink(right))
    blank = tmp_path / "blank.html"
    blank.write_text("<html><body></body></html>")
    control = screenshot(blank, tmp_path / "blank.png", tmp_path / "profile")
    assert ink(control) == 0 and control.std() < 0.01
