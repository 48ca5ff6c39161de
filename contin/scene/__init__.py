"""Scenes: the YAML format, its schema and checks, the analysis registry, and the model a scene describes.
"""
