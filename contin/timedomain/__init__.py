"""Time integration of a model: the compiled integrator, shooting and Poincare sections.
"""
