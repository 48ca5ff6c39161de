"""Bifurcation diagrams built on the engine: starting points, branch switching, backbones and two-parameter curves.
"""
