"""Tutorial 01's webgui scene renders offline in a real browser (headless Chromium).

The page written by ``ngcontact.save_html`` must show the coloured field; as a control, the
page of ``Draw(..., filename=...)``, which loads webgui.js from a CDN, renders blank here.
"""
import os
import pathlib
import shutil
import subprocess

import nbformat
import ngsolve as ngs
import numpy as np
import pytest
from matplotlib.image import imread
from nbclient import NotebookClient
from ngsolve.webgui import Draw

from ngcontact.geometries import plate

CHROMIUM = shutil.which("chromium")
TUTORIAL = pathlib.Path(__file__).parents[1] / "tutorials" / "01_quick_start.ipynb"
pytestmark = pytest.mark.skipif(CHROMIUM is None and not os.environ.get("CI"),
                                reason="needs Debian's chromium (.ci/run installs it)")


def screenshot(page, png, profile, size=(900, 600)):
    """Headless Chromium, offline, ``size`` (width, height) pixels; returns the RGB image as floats
    in [0, 1]."""
    subprocess.run([CHROMIUM or "chromium", "--headless", "--no-sandbox", "--disable-gpu",
                    "--disable-quic", "--no-first-run", "--disable-background-networking",
                    "--disable-component-update", "--disable-sync", f"--user-data-dir={profile}",
                    f"--window-size={size[0]},{size[1]}", "--virtual-time-budget=5000", f"--screenshot={png}",
                    page.as_uri()], check=True, timeout=600, capture_output=True)
    return imread(png)[..., :3]


def field_pixels(image):
    """Saturated (colour-map) pixels below the colour bar band at the top: the drawn field."""
    body = image[80:, :]
    saturation = body.max(axis=2) - body.min(axis=2)
    return body[saturation > 0.3]


def test_tutorial01_scene_renders_offline(tmp_path):
    notebook = nbformat.read(TUTORIAL, as_version=4)
    NotebookClient(notebook, timeout=600, kernel_name="python3",
                   resources={"metadata": {"path": str(tmp_path)}}).execute()
    page = tmp_path / "quickstart.html"
    assert page.stat().st_size > 100_000 and "cdn" not in page.read_text()[:5000].lower()
    image = screenshot(page, tmp_path / "quickstart.png", tmp_path / "profile")
    pixels = field_pixels(image)
    assert len(pixels) > 0.02 * image.shape[0] * image.shape[1]            # the field fills the view
    colours = np.unique(np.round(pixels * 31).astype(int), axis=0)
    assert len(colours) > 20                                                # a colour map, not a flat fill
    hues = {"red": (pixels[:, 0] > 0.7) & (pixels[:, 2] < 0.3), "blue": (pixels[:, 2] > 0.7) & (pixels[:, 0] < 0.3)}
    assert sum(mask.any() for mask in hues.values()) >= 1


def test_cdn_page_is_blank_offline(tmp_path):
    """The control: the same kind of scene through Draw(filename=...) shows no field offline,
    so the pixel check above can tell a rendered page from a blank one."""
    mesh = plate(maxh=0.01)
    gf = ngs.GridFunction(ngs.H1(mesh, order=1))
    gf.Set(ngs.x)
    Draw(gf, mesh, "x", filename=str(tmp_path / "cdn.html"))
    image = screenshot(tmp_path / "cdn.html", tmp_path / "cdn.png", tmp_path / "profile")
    assert len(field_pixels(image)) < 0.001 * image.shape[0] * image.shape[1]
