"""Scene geometries for ngcontact: Netgen meshes with named boundaries.

Installed as ``ngcontact.geometries`` (``from ngcontact.geometries import plate``); in a
checkout, ``ngcontact/geometries`` links to this folder.
"""
from .plate import block, plate

__all__ = ["plate", "block"]
