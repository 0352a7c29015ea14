"""Γ3, the contact side: the contact data (2.7)-(2.10) and everything that lives on Γ3.

Owns ``Contact`` and its laws (the compliant layer p, the glue's R_ν, the conduction ψ and φ_L),
the ContactSide (facets, sample and Gauss points), the bonding field β (2.9), the obstacles,
the enforcement methods of Signorini's condition (``enforcement``: Nitsche, penalty, the nodal
constraint), the Γ3 terms of the step residual (``terms``), the laws' switches Newton reads
(``switches``), and ``build``, which assembles Γ3 for a simulation.

``ngcontact.gamma3.build`` as a name is that function (``from ngcontact.gamma3 import build``, as
when Γ3 was one module), with ``Gamma3`` and ``gamma3_data``; the module that holds them is
imported by its path (``from ngcontact.gamma3.build import gamma3_data``, or
``sys.modules["ngcontact.gamma3.build"]``), never as an attribute of this package.

May import: the foundation and ``ngcontact.model``.
"""
from ngcontact.gamma3.build import Gamma3, build, gamma3_data  # (the name ``build``: the function)
from ngcontact.moved import submodule as _submodule

__all__ = ["Gamma3", "build", "gamma3_data"]


def __getattr__(name):
    """A module of the layer, imported at its first read (PEP 562)."""
    return _submodule(__name__, name)
