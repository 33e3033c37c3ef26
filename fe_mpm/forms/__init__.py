"""UFL weak forms of fe-mpm, one module per formulation.

- :mod:`fe_mpm.forms.displacement`: the irreducible (u) form at finite strain.
"""
