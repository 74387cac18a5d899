"""The clinical workflow: synthetic Fugl-Meyer cohorts (``cohort``), their analysis (``fma``), its
manifest checks, the analyses beyond the paper's label, and the multi-seed ``patient-study``.

May import the core of :mod:`scenarios` and ``fusion``, ``fma``, ``sim``; no other workflow, no CLI.
"""
