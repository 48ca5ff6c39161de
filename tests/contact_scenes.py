"""Small contact scenes shared by the tests of grazing ends (tests/ is on ``sys.path`` through its conftest)."""

#: a Jeffcott rotor pressed on its casing (radial clearance d) by f0 and driven by its unbalance
JEFFCOTT = """
model:
  dofs: [x, y]
  parameters: {c: 0.05, d: 0.1, kc: 1.0e4, e: 0.05, f0: 0.5, w: 1.0}
  mass: [[1, 0], [0, 1]]
  damping: [[c, 0], [0, c]]
  stiffness: [[1, 0], [0, 1]]
  forces:
    - {type: radial_gap, dofs: [x, y], clearance: d, stiffness: kc, damping: 0}
  excitation:
    - {dof: x, expr: "e*w**2*cos(tau)"}
    - {dof: y, expr: "e*w**2*sin(tau) - f0"}
  frequency: w
"""


def jeffcott(analysis: str) -> str:
    """:data:`JEFFCOTT` with the ``analysis`` section (YAML text, from ``analysis:`` on) appended."""
    return JEFFCOTT + analysis
