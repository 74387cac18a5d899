"""The clinical workflow: synthetic Fugl-Meyer cohorts (``cohort``) and their self-describing files
(vocabulary, participants, datasheet), cohort exports (CSV, C3D, TRC, Motion-BIDS), their analysis
(``fma``), its manifest checks, the analyses beyond the paper's label, and the multi-seed ``patient-study``.

May import the core of :mod:`scenarios` and ``fusion``, ``fma``, ``sim``; no other workflow, no CLI.
"""
