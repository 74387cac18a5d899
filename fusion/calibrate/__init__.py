"""Stage calibrate: camera clocks and sync, Kabsch and RANSAC over joints, ICP on body and floor,
the rig graph and the calibration pipeline that ties them.

May import the data model at the top of :mod:`fusion` and :mod:`fusion.io`; not merge or live.
"""
