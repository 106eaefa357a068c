"""Exporters: the only modules that import ezdxf, trimesh, manifold3d or matplotlib."""
