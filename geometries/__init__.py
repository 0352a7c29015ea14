"""Scene geometries for ngcontact: Netgen meshes with named boundaries."""
from .plate import block, plate

__all__ = ["plate", "block"]
