"""The continuation engine: follows R(u, lambda) = 0 and reports events. Knows nothing of vibrations.

- :mod:`~contin.engine.branch`: the result object (points, special points, status)
- :mod:`~contin.engine.newton`: the corrector's linear algebra and Newton's method
- :mod:`~contin.engine.events`: test functions and their location
- :mod:`~contin.engine.continuation`: the pseudo-arclength driver
"""
