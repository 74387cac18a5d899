"""The hostile suite (``hostile``): bad inputs through every reader and command, each outcome
classified. The command runner is passed in (the CLI's ``main``), so nothing here imports the CLI.

May import the core of :mod:`scenarios` and ``fusion``, ``sim``; no other workflow, no CLI.
"""
