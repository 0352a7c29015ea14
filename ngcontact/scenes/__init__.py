"""Ready scenes, built with the public API: the reference plate (``scenes.reference``), the
soft column (``scenes.column``) and manufactured solutions with a known contact set
(``scenes.manufactured``, which needs sympy). Import the one you need:
``from ngcontact.scenes import reference``."""
