"""Self-contained HTML pages of ``ngsolve.webgui`` scenes.

``ngsolve.webgui.Draw`` and ``Draw(..., filename=...)`` load ``webgui.js`` from a CDN, so the
page is blank without internet. ``save_html`` inlines the script shipped by the PyPI package
``webgui-jupyter-widgets``, so the page renders offline (any browser, no server).
"""
import pathlib


def save_html(filename, *args, **kwargs):
    """Draw a scene as ``ngsolve.webgui.Draw(*args, **kwargs)`` does and save it as a
    standalone HTML page; returns the path.

    Example: ``save_html("u.html", sim.u, mesh, "displacement", deformation=sim.u)``.
    """
    from ngsolve.webgui import Draw
    from webgui_jupyter_widgets.html import GenerateHTML
    path = pathlib.Path(filename)
    path.parent.mkdir(parents=True, exist_ok=True)
    scene = Draw(*args, show=False, **kwargs)
    GenerateHTML(scene.GetData(), filename=str(path))
    return path
