"""Mechanical models: linear matrices plus force and excitation elements, expressions and their compiled kernels, the catalogue of built-in models.
"""
