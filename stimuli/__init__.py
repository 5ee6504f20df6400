"""Thermal model of a fingertip touching a material (filled by issue 2)."""
