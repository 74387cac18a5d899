"""Studies of calibration and fusion over seeds and layouts: ``calib-study``, ``layout``,
``angle-study`` and the joint-angle figure.

May import the core of :mod:`scenarios` and ``fusion``, ``fma``, ``sim``; no other workflow, no CLI.
"""
