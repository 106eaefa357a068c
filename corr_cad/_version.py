"""The package version, in one place (read by the manifest, DXF headers and report)."""

__version__ = "0.1.0"
