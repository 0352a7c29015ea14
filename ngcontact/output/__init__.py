"""What a run leaves: the records of each step, what is recorded on Γ3 and at the supports
(``observables``), streamed results and resume, the scene's fingerprint, ParaView and webgui
output, progress bars.

May import: the foundation, ``ngcontact.model``, ``ngcontact.gamma3`` and ``ngcontact.time``
(its smallest time step).
"""
from ngcontact.moved import submodule as _submodule


def __getattr__(name):
    """A module of the layer, imported at its first read (PEP 562)."""
    return _submodule(__name__, name)
