"""One step's solve: the step system R(x) = 0 and the semismooth Newton method that solves it.

Owns the ``StepSystem`` (bulk and Γ3 forms, condensation, the laws' terms), ``Newton`` with its
stopping test, step-length cut, line search, cycle detection and continuation, Newton's starts
(guesses, nested iteration), and, in ``linalg``, the linear solvers of a correction.

May import: the foundation, ``ngcontact.model`` and ``ngcontact.gamma3``; ``linalg`` only the
foundation and ``model``.
"""
