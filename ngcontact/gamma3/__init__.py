"""Γ3, the contact side: the contact data (2.7)-(2.10) and everything that lives on Γ3.

Owns ``Contact`` and its laws (the compliant layer p, the glue's R_ν, the conduction ψ and φ_L),
the ContactSide (facets, sample and Gauss points), the bonding field β (2.9), the obstacles,
the enforcement methods of Signorini's condition (``enforcement``: Nitsche, penalty, the nodal
constraint), the Γ3 terms of the step residual (``terms``), the laws' switches Newton reads
(``switches``), and ``build``, which assembles Γ3 for a simulation.

May import: the foundation and ``ngcontact.model``.
"""
