"""Self-contained HTML pages of ``ngsolve.webgui`` scenes.

``ngsolve.webgui.Draw`` and ``Draw(..., filename=...)`` load ``webgui.js`` from a CDN, so the
page is blank without internet. ``save_html`` inlines the script shipped by the PyPI package
``webgui-jupyter-widgets``, so the page renders offline (any browser, no server).
"""
import numbers
import os
import pathlib


def save_html(filename, *args, **kwargs):
    """Draw a scene as ``ngsolve.webgui.Draw(*args, **kwargs)`` does and save it as a
    standalone HTML page; returns the path.

    Example: ``save_html("u.html", sim.u, mesh, "displacement", deformation=sim.u)``.
    ``filename`` a str or path; the object drawn (the first of ``args``) a GridFunction, a Mesh,
    a CoefficientFunction followed by its Mesh, or a Netgen mesh or geometry: a TypeError naming
    them otherwise, before anything is written.
    """
    import ngsolve as ngs
    if not isinstance(filename, (str, os.PathLike)) or not str(filename):
        raise TypeError(f"save_html: filename must be a path (str or pathlib.Path) of the page to write, got "
                        f"{filename!r} ({type(filename).__name__})")
    drawn = args[0] if args else kwargs.get("obj")
    if drawn is None or isinstance(drawn, (str, bytes, numbers.Number, os.PathLike)):
        raise TypeError(f"save_html(filename, obj, ...): obj, the object to draw, must be a GridFunction, a Mesh, a "
                        f"CoefficientFunction followed by its Mesh, or a Netgen mesh or geometry, got "
                        f"{type(drawn).__name__ if args or 'obj' in kwargs else 'nothing'}")
    if isinstance(drawn, ngs.CoefficientFunction) and not isinstance(drawn, ngs.GridFunction) and \
            not (len(args) > 1 and isinstance(args[1], ngs.Mesh)) and not isinstance(kwargs.get("mesh"), ngs.Mesh):
        raise TypeError("save_html(filename, cf, mesh, ...): a CoefficientFunction is drawn on a mesh: give the "
                        "ngsolve.Mesh after it")
    from ngsolve.webgui import Draw                               # slow to import: after the checks
    from webgui_jupyter_widgets.html import GenerateHTML
    path = pathlib.Path(filename)
    path.parent.mkdir(parents=True, exist_ok=True)
    scene = Draw(*args, show=False, **kwargs)
    GenerateHTML(scene.GetData(), filename=str(path))
    return path
