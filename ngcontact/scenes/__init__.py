"""Ready scenes, built with the public API: the reference plate (``reference``), the soft
column (``column``) and manufactured solutions with a known contact set (``manufactured``)."""
from . import column, manufactured, reference

__all__ = ["reference", "column", "manufactured"]
