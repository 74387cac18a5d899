"""The camera-layout planner (``plan``): room files, the geometric screen, the objectives of one
layout, the search and its report.

May import the core of :mod:`scenarios` and ``fusion``, ``sim``; no other workflow, no CLI.
"""
