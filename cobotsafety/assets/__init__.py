"""Bundled data: robot capsules, recordings (see README.md in this folder)."""
