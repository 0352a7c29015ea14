"""Sphinx configuration: ``pip install ".[docs]"`` then ``python -m sphinx -W -b html docs OUT``.

The pages are Markdown (MyST), the API reference is generated from the package's docstrings
(autodoc, numpy-style sections read by napoleon), and the tutorials (``docs/tutorials`` links to
the repository's ``tutorials/``) are rendered by MyST-NB without being executed: the notebooks
are stored without outputs, and running them takes minutes (the test suite runs them).
"""
import pathlib
import sys

HERE = pathlib.Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))                 # this checkout's ngcontact, installed or not

project = "ngcontact"
author = "the ngcontact authors"
copyright = "ngcontact authors"

extensions = ["myst_nb", "sphinx.ext.autodoc", "sphinx.ext.napoleon"]

source_suffix = {".rst": "restructuredtext", ".md": "myst-nb", ".ipynb": "myst-nb"}
root_doc = "index"
# the figures' and studies' folders beside the topic pages hold data (csv, png, scripts, tables
# of a study's runs), not pages; the pages link their files directly
exclude_patterns = ["_build", "**/.ipynb_checkpoints",
                    *(p.name for p in HERE.iterdir() if p.is_dir() and p.name not in ("api", "tutorials", "_static"))]

nb_execution_mode = "off"                            # rendered as stored (no outputs), never run at build
myst_heading_anchors = 3                             # links like model.md#sign-conventions resolve
myst_enable_extensions = ["dollarmath"]

autodoc_default_options = {"member-order": "bysource"}       # members listed where a page wants them
autodoc_typehints = "description"
autodoc_preserve_defaults = True                     # signatures show `time=None`, not a repr of an object
autoclass_content = "both"                           # the class docstring and __init__'s
napoleon_numpy_docstring = True
napoleon_google_docstring = False
napoleon_use_rtype = False

html_theme = "alabaster"
html_title = "ngcontact"
html_theme_options = {"description": "Piezoelectric viscoelastic contact with adhesion, on NGSolve",
                      "page_width": "1100px", "sidebar_width": "240px"}


# ---- the docstrings as RST ------------------------------------------------------------------
# The package's docstrings are written to be read in a terminal (``help()``): |x| for norms,
# "name : text" lines with indented continuations, a paragraph followed by an indented line.
# Read as reStructuredText those are substitutions, definition lists and block quotes without
# their blank lines. Before napoleon reads its numpy sections, each docstring gets the blank
# lines RST needs where the indentation changes, and |, * and a trailing _ escaped outside
# ``literals``; the text itself is unchanged.
import re                                                                  # noqa: E402

SECTION = re.compile(r"^\s*(Parameters|Returns|Yields|Raises|Warns|Attributes|Other Parameters|Examples|"
                     r"Notes|References|See Also|Methods)\s*$")
FIELD = re.compile(r"^[\w*, ]+ :( |$)")
FIELD_TEXT = re.compile(r"^([\w*, ]+) : (.+)$")
DESCRIBED = ("Parameters", "Other Parameters", "Attributes")
ENTRY = re.compile(r"^([A-Za-z_]\w*(?:, [A-Za-z_]\w*)*) : (.+)$")
BULLET = re.compile(r"^(\s*)([-*+•]|\d+[.)])\s+")


def _escape(line):
    """|, * (but a bullet's) and a word's trailing _ escaped outside ``literals``."""
    bullet = BULLET.match(line)
    head, line = (line[:bullet.end()], line[bullet.end():]) if bullet else ("", line)
    parts = line.split("``")
    for i in range(0, len(parts), 2):
        part = parts[i].replace("\\", "\\\\").replace("|", "\\|").replace("*", "\\*")
        parts[i] = re.sub(r"(?<=\w)_(?=\W|$)", r"\\_", part)
    return head + "``".join(parts)


def _indent(line):
    return len(line) - len(line.lstrip())


def _as_rst(lines):
    """The docstring's lines with the blank lines RST needs and the escapes above."""
    out, previous, literal, in_section, bullets, entry = [], None, None, False, [], None    # entry: a list's indent
    for index, line in enumerate(lines):
        if not line.strip():
            out.append(line)
            previous, bullets, entry = None, [], None
            continue
        indent = _indent(line)
        if literal is not None and indent > literal:                      # inside a literal block: as is
            out.append(line)
            continue
        literal = None
        following = lines[index + 1] if index + 1 < len(lines) else ""
        if SECTION.match(line) and re.match(r"^\s*-{3,}\s*$", following):
            in_section = SECTION.match(line).group(1)
        elif in_section and indent == 0 and previous is None and not FIELD.match(line):
            out += ["Notes", "-----"]          # prose after a numpy section: napoleon ends it at a header only
            in_section = False
        if not in_section:                     # "name : text" lines with indented continuations: a list
            item = ENTRY.match(line.strip())
            if entry is not None and indent > entry:
                out.append(" " * (entry + 2) + _escape(line.strip()))          # an entry's continuation
                continue
            if item:
                if previous is not None and entry != indent:
                    out.append("")
                out.append(" " * indent + f"- ``{item.group(1)}`` : " + _escape(item.group(2)))
                entry, previous, bullets = indent, (indent, indent + 2), [indent]
                continue
            if entry is not None:
                out.append("")
                entry, previous, bullets = None, None, []
        bullet = BULLET.match(line)
        if previous is not None and not in_section and not re.match(r"^\s*-{3,}\s*$", line):
            text_column = previous[1]
            same_list = bullet and bullet.end(1) in bullets
            if indent != text_column and not same_list:
                out.append("")
                bullets = []
        if bullet:
            bullets.append(bullet.end(1))
        field = FIELD_TEXT.match(line) if in_section in DESCRIBED else None
        if field and indent == 0:              # "name : what it is": the text is the description, not a type
            out += [field.group(1), "    " + _escape(field.group(2))]
        else:
            out.append(line if in_section and re.match(r"^\s*-{3,}\s*$", line) else _escape(line))
        previous = (indent, bullet.end() if bullet else indent)
        if line.rstrip().endswith("::"):
            literal = indent
            out.append("")
            previous = None
    return out


def _docstring(app, what, name, obj, options, lines):
    lines[:] = _as_rst(lines)


def _tutorial_links(app, docname, source):
    """A topic page's link to ``../tutorials/NN.ipynb`` (right on the repository) is the rendered
    tutorial in the site (``docs/tutorials`` links to the folder; a path through the link would
    resolve outside docs/, so the link becomes a reference to the document)."""
    source[0] = re.sub(r"\[([^\]]+)\]\(\.\./tutorials/(\w+)\.ipynb\)", r"{doc}`\1 <tutorials/\2>`", source[0])


def setup(app):
    app.connect("autodoc-process-docstring", _docstring, priority=100)     # before napoleon (500)
    app.connect("source-read", _tutorial_links)
