"""The scene text of a forced linear oscillator, x'' + 0.2 x' + 2 x = 0.5 cos(w t), harmonics 1, no stability.

Its response is the closed form 0.5 / |2 - w^2 + 0.2 i w|; tests append their own keys (``continuation``,
``output``) to :data:`LINEAR_OSCILLATOR`, whose last line is in the analysis section.
"""

LINEAR_OSCILLATOR = """
model:
  dofs: [x]
  parameters: {m: 1.0, c: 0.2, k: 2.0, F: 0.5, w: 1.0}
  mass: [[m]]
  damping: [[c]]
  stiffness: [[k]]
  excitation: [{dof: x, expr: "F*cos(tau)"}]
analysis:
  type: frequency_response
  range: [0.5, 2.5]
  harmonics: 1
  stability: none
"""
