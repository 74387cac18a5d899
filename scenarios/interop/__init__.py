"""Real-sensor files and recorded motion at the command line: ``import``, ``write``, ``roundtrip``
and the retargeting report of several motion sources.

May import the core of :mod:`scenarios` and ``fusion``, ``sim``; no other workflow, no CLI.
"""
