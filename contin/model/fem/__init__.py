"""Finite-element rotors: lateral matrices imported from ROSS, contact at named nodes, modal reduction.

- :mod:`contin.model.fem.coefficients`: bearing coefficients that vary with the speed (B-splines).
- :mod:`contin.model.fem.matrices`: :class:`RotorMatrices`, a rotor's lateral matrices and bearing tables,
  stored as ``.npz`` (no ROSS needed to read them).
- :mod:`contin.model.fem.ross_bridge`: :func:`from_ross` reads a ``ross.Rotor`` (optional extra ``contin[ross]``).
- :mod:`contin.model.fem.reduction`: the Craig-Bampton basis.
- :mod:`contin.model.fem.builder`: :func:`fe_rotor_model`, a :class:`contin.model.base.Model` with a clearance
  contact, unbalance and a side load.
"""
