"""Pixel-space understanding of the photo: class lookups, objects from masks and boxes, depth."""
