"""Studies of calibration and fusion over seeds and layouts: ``calib-study``, ``layout``,
``angle-study``, the joint-angle figure and the ``demo``.

May import the core of :mod:`scenarios` and ``fusion``, ``fma``, ``sim``; no other workflow, no CLI.
"""
