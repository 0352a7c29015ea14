"""No hard-coded timings in the prose: a time or a speed ratio depends on the machine, its load
and the commit, so the tutorials' text refers to what their code cells print, and a topic page of
docs/ quotes one only in a section that says when it was measured (a commit or a date).

The pages that are records of measurements are not scanned: ``RECORDS``.
"""
import json
import pathlib
import re

import pytest

ROOT = pathlib.Path(__file__).parents[1]
RECORDS = {"measurements.md", "history.md", "speed.md", "scale.md", "cluster.md"}
"""docs/ pages that are the record of measured runs, each with its commit, date and machine:
the measurements behind the package's constants, the history, the speed benchmark, the 3D
solvers at scale and the MPI campaign."""
DURATION = r"\d+(?:[.,]\d+)?(?:\s*[–-]\s*\d+(?:[.,]\d+)?)?\s*(?:s|ms|min|minutes?|seconds?|h|hours?)\b"
TIMING = [
    # a run that takes, costs or finishes in a duration: "takes 31–36 s", "runs in about 2 min"
    re.compile(r"\b(?:takes?|took|taking|runs? in|ran in|finish(?:es|ed)? in|costs?|spends?|spent)\b"
               r"(?:\s+\S+){0,3}?\s+(?:about\s+|only\s+|under\s+|over\s+|around\s+|some\s+|just\s+)?" + DURATION, re.I),
    # a speed ratio: "20 times less", "12× faster", "4x the time" (not "2 times more accurate")
    re.compile(r"\b\d+(?:[.,]\d+)?\s*(?:times|[×x])\s+(?:faster|slower|quicker|cheaper|dearer|longer|the time|"
               r"(?:less|more)(?=\s*(?:[,.;:)]|$|time|wall|than)))", re.I),
    re.compile(r"\b(?:faster|slower|quicker|cheaper)\s+by\s+(?:a\s+factor\s+(?:of\s+)?)?\d", re.I),
    # a duration on a machine: "1.5 min on 2 cores", "31 s on this machine"
    re.compile(DURATION + r"\s+on\s+(?:this|a|one|the|\d+)\s+(?:machine|cores?|threads?|laptop)", re.I),
]
DATED = re.compile(r"\b(?=[0-9a-f]*[a-f])(?=[0-9a-f]*\d)[0-9a-f]{7,40}\b|\b20\d\d-\d\d-\d\d\b")
"""A commit (7 to 40 hex digits, letters and digits) or a date (YYYY-MM-DD)."""


def timings(text):
    """The timing phrases of ``text`` (whitespace folded), each with a little context."""
    text = re.sub(r"\s+", " ", text)
    return [text[max(0, m.start() - 40):m.end() + 20] for pattern in TIMING for m in pattern.finditer(text)]


def markdown_cells(path):
    return ["".join(cell["source"]) for cell in json.loads(path.read_text())["cells"] if cell["cell_type"] == "markdown"]


TUTORIAL_10_BEFORE = """At full size the 3D quarter (17 140 DOFs, 30 Newton iterations over the 4 steps) comes within
1.0 % of the section's force and 0.7 % of its charge, and takes 31–36 s on this machine
(shared with other work), of which 5–7 s compile the Γ3 integrand to machine code (ngcontact
does so once the iterations pay for it); the section (7 965 DOFs, 43 iterations) takes 1.6 s,
about 20 times less, with a mesh four times finer under the tip. In the quick run (2 µm in
3D, 1 µm on the section) the 3D force is 3.5 % above the section's, for about 10 s against
0.1 s."""
"""Tutorial 10's text before it referred to its printed numbers."""


def test_the_scan_finds_the_timings_tutorial_10_hard_coded():
    found = timings(TUTORIAL_10_BEFORE)
    assert any("takes 31–36 s" in f for f in found) and any("takes 1.6 s" in f for f in found)
    assert any("20 times less" in f for f in found) and any("36 s on this machine" in f for f in found)


@pytest.mark.parametrize("text", [
    "The pressure ramps to 2 MPa at t = 0.1 s, holds until 0.15 s.",       # the model's time
    "the explicit update is stable for k ≤ 4 ms; τ = 2 ms",
    "At 20 ms the last step (t = 0.2 s) needs no cut-back at 25 ms.",
    "P2 and P3 are 2–3 times more accurate than P1.",                      # not a speed
    "a try 4× shorter than the first one rejected",
    "the prints below give its solve time and the ratio of the two.",
])
def test_the_scan_leaves_the_model_s_times_alone(text):
    assert timings(text) == []


@pytest.mark.parametrize("path", sorted((ROOT / "tutorials").glob("*.ipynb")), ids=lambda p: p.name)
def test_tutorial_prose_has_no_hard_coded_timing(path):
    found = [f for cell in markdown_cells(path) for f in timings(cell)]
    assert not found, f"{path.name}: print the run's own time in a code cell and refer to it: {found}"


@pytest.mark.parametrize("path", sorted(p for p in (ROOT / "docs").glob("*.md") if p.name not in RECORDS),
                         ids=lambda p: p.name)
def test_docs_quote_a_timing_only_with_the_run_that_measured_it(path):
    sections = re.split(r"\n(?=#)", path.read_text())
    found = [f for section in sections if not DATED.search(section) for f in timings(section)]
    assert not found, (f"docs/{path.name}: a timing in a section that names no commit or date of its run "
                       f"(a measurement belongs to a measured run): {found}")
