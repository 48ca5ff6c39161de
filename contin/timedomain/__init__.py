"""Time integration of a model: the compiled integrator, shooting and Poincare sections.
Spectral lines (frequency, amplitude, phase) of recorded signals: :mod:`contin.timedomain.spectral_lines`.
"""
