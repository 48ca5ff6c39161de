"""The static and linear picture of a model: static equilibrium, tangent matrices, natural and damped modes, FRFs, the vibration absorber's closed forms.
"""
