"""Small helpers every layer may use: name hints, number tests, BLAS thread limits. Imports nothing from contin.
"""
