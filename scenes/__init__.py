"""The example scenes of contin and the files they read, installed as the package ``contin.scenes``.

``contin examples`` lists them, ``contin run NAME`` runs one by its name and
``contin examples --copy DIR`` copies them all (:mod:`contin.app.examples`).
"""
