"""Harmonic balance: the residual R(u, lambda) of a model, its derivatives, AFT, contact crossings, condensation and per-point measures.
"""
