"""UFL weak forms of fe-mpm, one module per formulation.

- :mod:`fe_mpm.forms.displacement`: the irreducible (u) form at finite strain.
- :mod:`fe_mpm.forms.ghost`: the ghost penalty on the facets of poorly filled cells.
"""
