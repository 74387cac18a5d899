"""The camera-layout planner (``plan``): room files, the geometric screen, the objectives of one
layout, the search with its statistics and sanity rules, the user's own layouts (rig files), the
report and the install sheets.

May import the core of :mod:`scenarios` and ``fusion``, ``sim``; no other workflow, no CLI.
"""
