"""Raster primitives: lines, anti-aliased lines, polygon fill and z-buffered
triangles (``fcol.raster``)."""

from __future__ import annotations

__all__: list[str] = []
